"""``python -m rvn_rl.depth.cli out_dir=... pairs.train_scenes=... pairs.per_scene=... train.steps=...
image_size=128``: render pairs, train the depth model, evaluate it on the val scenes.

Hydra config ``conf/rl_depth.yaml`` (composed with Hydra's compose API: overrides as on
the command line, no Hydra run folder); its schema is `rvn_rl.depth.settings.DepthConfig`
(``base_rl_depth``), into which the config is turned once. Writes into ``out_dir``: ``model.safetensors`` +
``model.json`` (load with `rvn_rl.depth.load_depth_model`), ``metrics.json`` (val AbsRel,
delta1, RMSE; the two baselines; AbsRel on training frames at init and after training; the
training log), ``predictions.png``, ``config.yaml`` and ``pairs/{train,val}.h5``. Val scenes that are train scenes
too (a mesh folder without split folders, a list file) are noted on stderr, in metrics.json (``shared_scenes``) and
in the summary. Bad input exits with status 2 and one line, a run that fails with status 1 (`rvn_data.cli.common`).
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import yaml

from rvn_data.atomic import write_text_atomic
from rvn_data.cli.common import BAD_INPUT, RUN_FAILED, ConfigError, check_writable_dir, one_line, validating

from .settings import DepthConfig, register_schema

PROG = "rvn_rl.depth.cli"
TRAIN_SUBSET = 64  # training frames on which AbsRel is measured at init and after training
SPLITS = ("train", "val")


def compose(overrides: list[str]) -> DepthConfig:
    """The typed settings for command-line ``overrides`` (`DepthConfig`; a ValueError naming a bad key or value)."""
    from rvn_data.config import load_config, typed

    register_schema()
    return typed(DepthConfig, load_config("rl_depth", overrides))


def scene_specs(cfg: DepthConfig) -> dict:
    """Each split's (scene spec, index) list of the ``scenes`` group's source; a ValueError when a split has fewer
    scenes than asked."""
    from .pairs import split_scenes

    return {split: split_scenes(cfg.scenes.source, split, getattr(cfg.pairs, f"{split}_scenes"), root=cfg.scenes.root)
            for split in SPLITS}


def shared_scenes(cfg: DepthConfig, specs: dict) -> dict | None:
    """The val scenes that are train scenes too (``scenes.root`` gives both splits the same meshes: a mesh folder
    without ``train/`` and ``val/`` folders, a list file, one mesh), as metrics.json records them; None when none is."""
    train = {spec for spec, _ in specs["train"]}
    shared = [spec for spec, _ in specs["val"] if spec in train]
    if not shared:
        return None
    return {"folder": str(Path(str(cfg.scenes.root)).expanduser()), "val_scenes": len(specs["val"]),
            "in_train": len(shared)}


def shared_scenes_note(shared: dict) -> str:
    """One line saying that the val pairs are not of held-out scenes (`shared_scenes`)."""
    root = shared["folder"]
    return (f"{shared['in_train']} of the {shared['val_scenes']} val scenes are train scenes too: scenes.root={root} "
            f"gives both splits the same meshes, so the val metrics are not on held-out scenes; put each split's "
            f"meshes in a folder of its own ({root}/train, {root}/val) to keep them apart")


def make_all_pairs(cfg: DepthConfig, specs: dict, out_dir: Path) -> dict:
    """Render (or reuse) train.h5 and val.h5; returns their paths and what was done."""
    from .pairs import make_pairs, scene_options

    pairs_dir = Path(cfg.pairs.dir or out_dir / "pairs").expanduser()
    return {split: make_pairs(pairs_dir / f"{split}.h5", split, specs[split], cfg.pairs.per_scene, cfg.seed, cfg.camera,
                              cfg.navmesh, cfg.renderer, progress=cfg.progress, scenes=scene_options(cfg.scenes))
            for split in SPLITS}


def run(cfg: DepthConfig) -> dict:
    import torch

    from .model import DepthNet, save_depth_model
    from .pairs import read_pairs, scene_options
    from .report import summary, write_predictions_png
    from .train import baseline_metrics, depth_metrics, evaluate, median_depth, predict, train_depth as fit

    with validating():  # bad input: exit status 2, nothing written
        out_dir = check_writable_dir(Path(cfg.out_dir).expanduser())
        specs = scene_specs(cfg)
    if cfg.threads is not None:
        torch.set_num_threads(cfg.threads)
    shared = shared_scenes(cfg, specs)
    if shared:  # as rvn-gen and rvn-eval say of a mesh folder without split folders (rvn_data.scenes.sets.shared_splits)
        print(f"{PROG}: note: {shared_scenes_note(shared)} (recorded in metrics.json)", file=sys.stderr)
    torch.manual_seed(cfg.seed)
    done = make_all_pairs(cfg, specs, out_dir)
    train_rgb, train_depth = read_pairs(done["train"][0])
    val_rgb, val_depth = read_pairs(done["val"][0])
    net = DepthNet(**asdict(cfg.model), init_depth=median_depth(train_depth))
    subset = np.linspace(0, len(train_rgb) - 1, min(TRAIN_SUBSET, len(train_rgb))).round().astype(int)
    init = evaluate(net, train_rgb[subset], train_depth[subset])
    t0 = time.perf_counter()
    log = fit(net, train_rgb, train_depth, cfg.train, cfg.seed, val=(val_rgb, val_depth), progress=cfg.progress)
    seconds = time.perf_counter() - t0
    val_pred = predict(net, val_rgb)
    val = depth_metrics(val_pred, val_depth)
    p, s = cfg.pairs, cfg.train
    metrics = {
        "val": val,
        "baselines": baseline_metrics(train_depth, val_depth),
        "train_subset": {"frames": len(subset), "init": init, "final": evaluate(net, train_rgb[subset],
                                                                                   train_depth[subset])},
        "pairs": {"train": len(train_rgb), "val": len(val_rgb), "train_scenes": p.train_scenes,
                  "val_scenes": p.val_scenes, "per_scene": p.per_scene,
                  "renderer": cfg.renderer.backend, "reused": {k: v[1] for k, v in done.items()}},
        "train": {"steps": s.steps, "batch_size": s.batch_size, "seconds": seconds,
                  "steps_per_s": s.steps / max(seconds, 1e-9),
                  "final_loss": float(np.mean([r["loss"] for r in log[-20:]])),
                  "threads": torch.get_num_threads()},
        "history": [r for r in log if "val" in r or r["step"] % 50 == 0 or r["step"] == s.steps],
        "image_size": cfg.image_size,
        "params": sum(p.numel() for p in net.parameters()),
    }
    if shared:  # the summary repeats the warning
        metrics["shared_scenes"] = shared
    save_depth_model(net, out_dir, cfg.image_size,
                     extra={"camera": asdict(cfg.camera), "seed": cfg.seed, "val": val,
                            "pairs": {"source": cfg.scenes.source,
                                      **{k: getattr(p, k) for k in ("train_scenes", "val_scenes", "per_scene")}},
                            "scenes": scene_options(cfg.scenes)})
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2) + "\n")
    write_predictions_png(out_dir / "predictions.png", val_rgb, val_depth, val_pred)
    write_text_atomic(out_dir / "config.yaml", yaml.safe_dump(asdict(cfg), sort_keys=False))
    metrics["summary"] = summary(metrics, out_dir)
    return metrics


def main(argv: list[str] | None = None) -> int:
    from omegaconf.errors import OmegaConfBaseException

    from rvn_data.scenes import SceneError

    argv = sys.argv[1:] if argv is None else argv
    if any(a in ("-h", "--help") for a in argv):
        print(__doc__)
        return 0
    from hydra.errors import HydraException

    try:
        from rvn_data.cli import overrides
        from rvn_data.config import CONF_DIR

        register_schema()
        overrides.check(PROG, "rl_depth", CONF_DIR, argv)  # a typo'd key or a wrong type (with or without +): one line
        cfg = compose(argv)  # typed once; each settings dataclass checks its own ranges
    except (ValueError, TypeError, KeyError, OmegaConfBaseException, HydraException) as err:
        print(f"{PROG}: error: {one_line(err)}", file=sys.stderr)
        return BAD_INPUT
    try:
        metrics = run(cfg)
    except (ValueError, TypeError, KeyError, SceneError, OSError) as err:  # ConfigError: BAD_INPUT
        print(f"{PROG}: error: {one_line(err)}", file=sys.stderr)
        return BAD_INPUT if isinstance(err, ConfigError) else RUN_FAILED
    print(metrics["summary"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
