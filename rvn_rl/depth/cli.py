"""``python -m rvn_rl.depth.cli out_dir=... pairs.train_scenes=... pairs.per_scene=... train.steps=...
image_size=128``: render pairs, train the depth model, evaluate it on the val scenes.

Hydra config ``conf/rl_depth.yaml`` (composed with Hydra's compose API: overrides as on
the command line, no Hydra run folder). Writes into ``out_dir``: ``model.safetensors`` +
``model.json`` (load with `rvn_rl.depth.load_depth_model`), ``metrics.json`` (val AbsRel,
delta1, RMSE; the two baselines; AbsRel on training frames at init and after training; the
training log), ``predictions.png``, ``config.yaml`` and ``pairs/{train,val}.h5``. Bad input
exits with status 2 and one line, a run that fails with status 1 (`rvn_data.cli.common`).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from rvn_data.atomic import write_text_atomic
from rvn_data.cli.common import BAD_INPUT, RUN_FAILED, ConfigError, check_writable_dir, one_line, validating

PROG = "rvn_rl.depth.cli"
TRAIN_SUBSET = 64  # training frames on which AbsRel is measured at init and after training


def _positive_int(name: str, value, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{name}={value!r} must be an integer >= {minimum}")
    return value


def compose(overrides: list[str]) -> dict:
    """The resolved config for command-line ``overrides``."""
    from omegaconf import OmegaConf

    from rvn_data.config import load_config

    cfg = load_config("rl_depth", overrides)
    return OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)


def check(cfg: dict) -> None:
    """One-line errors for settings that cannot work."""
    _positive_int("image_size", cfg["image_size"], 16)
    for key in ("train_scenes", "val_scenes", "per_scene"):
        _positive_int(f"pairs.{key}", cfg["pairs"][key])
    _positive_int("seed", cfg["seed"], 0)
    if cfg["threads"] is not None:
        _positive_int("threads", cfg["threads"])
    if not cfg.get("out_dir"):
        raise ValueError("out_dir is empty; give out_dir=<folder>")


def make_all_pairs(cfg: dict, out_dir: Path) -> dict:
    """Render (or reuse) train.h5 and val.h5; returns their paths and what was done."""
    from rvn_data.navmesh.settings import NavMeshSettings
    from rvn_data.render.camera import CameraConfig

    from .pairs import make_pairs, split_scenes

    camera = CameraConfig.from_dict(cfg["camera"])
    navmesh = NavMeshSettings.from_config(cfg["navmesh"])
    pairs_dir = Path(cfg["pairs"]["dir"] or out_dir / "pairs").expanduser()
    p = cfg["pairs"]
    specs = {split: split_scenes(p["source"], split, p[f"{split}_scenes"], root=p["root"]) for split in ("train", "val")}
    return {split: make_pairs(pairs_dir / f"{split}.h5", split, specs[split], p["per_scene"], cfg["seed"], camera,
                              navmesh, cfg["renderer"], progress=cfg["progress"]) for split in ("train", "val")}


def run(cfg: dict) -> dict:
    import torch

    from .model import DepthNet, save_depth_model
    from .pairs import read_pairs, split_scenes
    from .report import summary, write_predictions_png
    from .train import (TrainSettings, baseline_metrics, depth_metrics, evaluate, median_depth, predict,
                        train_depth as fit)

    with validating():  # bad input: exit status 2, nothing written
        check(cfg)
        settings = TrainSettings(**cfg["train"]).validate()
        out_dir = check_writable_dir(Path(cfg["out_dir"]).expanduser())
        p = cfg["pairs"]
        for split in ("train", "val"):
            split_scenes(p["source"], split, p[f"{split}_scenes"], root=p["root"])
    if cfg["threads"] is not None:
        torch.set_num_threads(cfg["threads"])
    torch.manual_seed(cfg["seed"])
    done = make_all_pairs(cfg, out_dir)
    train_rgb, train_depth = read_pairs(done["train"][0])
    val_rgb, val_depth = read_pairs(done["val"][0])
    net = DepthNet(**cfg["model"], init_depth=median_depth(train_depth))
    subset = np.linspace(0, len(train_rgb) - 1, min(TRAIN_SUBSET, len(train_rgb))).round().astype(int)
    init = evaluate(net, train_rgb[subset], train_depth[subset])
    t0 = time.perf_counter()
    log = fit(net, train_rgb, train_depth, settings, cfg["seed"], val=(val_rgb, val_depth),
                      progress=cfg["progress"])
    seconds = time.perf_counter() - t0
    val_pred = predict(net, val_rgb)
    val = depth_metrics(val_pred, val_depth)
    metrics = {
        "val": val,
        "baselines": baseline_metrics(train_depth, val_depth),
        "train_subset": {"frames": len(subset), "init": init, "final": evaluate(net, train_rgb[subset],
                                                                                   train_depth[subset])},
        "pairs": {"train": len(train_rgb), "val": len(val_rgb), "train_scenes": cfg["pairs"]["train_scenes"],
                  "val_scenes": cfg["pairs"]["val_scenes"], "per_scene": cfg["pairs"]["per_scene"],
                  "renderer": cfg["renderer"]["backend"], "reused": {k: v[1] for k, v in done.items()}},
        "train": {"steps": settings.steps, "batch_size": settings.batch_size, "seconds": seconds,
                  "steps_per_s": settings.steps / max(seconds, 1e-9),
                  "final_loss": float(np.mean([r["loss"] for r in log[-20:]])),
                  "threads": torch.get_num_threads()},
        "history": [r for r in log if "val" in r or r["step"] % 50 == 0 or r["step"] == settings.steps],
        "image_size": cfg["image_size"],
        "params": sum(p.numel() for p in net.parameters()),
    }
    save_depth_model(net, out_dir, cfg["image_size"],
                     extra={"camera": cfg["camera"], "seed": cfg["seed"], "val": val,
                            "pairs": {k: cfg["pairs"][k] for k in ("source", "train_scenes", "val_scenes", "per_scene")}})
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2) + "\n")
    write_predictions_png(out_dir / "predictions.png", val_rgb, val_depth, val_pred)
    write_text_atomic(out_dir / "config.yaml", yaml.safe_dump(cfg, sort_keys=False))
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
        from rvn_data.config import CONF_DIR, register_configs

        register_configs()
        overrides.check(PROG, "rl_depth", CONF_DIR, argv)  # a typo'd key, with or without +, in one line
        cfg = compose(argv)
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
