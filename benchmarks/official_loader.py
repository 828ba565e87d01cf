"""rvn-gen's dataset read by visualnav-transformer's own loader (its ``ViNT_Dataset``, which trains GNM, ViNT and
NoMaD) beside rvn-train's ``GNMDataset`` on the same folder: the samples each indexes, the waypoint and point-goal
labels of every sample both have (the goal offset rvn-train drew, given to the official label code), and the context
frames of every ``--every``-th one.

Needs a visualnav-transformer checkout (``git clone https://github.com/robodhruv/visualnav-transformer``) and what
its loader imports beside torch: ``pip install lmdb torchvision`` (the torchvision that matches your torch; where
only a CUDA build of it is at hand and torch is a CPU build, its C operators, which this loader does not use, fail
to load, and this script says so and goes on without them). The official package is copied to a scratch folder
with the dataset's ``data_config.yaml`` entry added, as docs/DATASET.md tells its users to do, and its split folder
is copied there too, since the official loader writes its caches beside ``traj_names.txt``: nothing is written into
the checkout or the dataset.

    rvn-gen scenes.num_scenes=3 trajectories_per_scene=8 out_dir=/tmp/rvn_small
    python benchmarks/official_loader.py --visualnav ~/visualnav-transformer --data /tmp/rvn_small
"""
from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import tempfile
import time
import types
from pathlib import Path

import numpy as np
import yaml


def official_dataset_class(visualnav: Path, data_config: dict, scratch: Path):
    """``ViNT_Dataset`` imported from a copy of the checkout's ``train/vint_train`` whose data_config.yaml has
    ``data_config``'s entries added."""
    package = visualnav / "train" / "vint_train"
    if not (package / "data" / "vint_dataset.py").is_file():
        sys.exit(f"--visualnav {visualnav}: no train/vint_train/data/vint_dataset.py; give a visualnav-transformer "
                 f"checkout (git clone https://github.com/robodhruv/visualnav-transformer)")
    shutil.copytree(package, scratch / "vint_train")
    configs = scratch / "vint_train" / "data" / "data_config.yaml"
    configs.write_text(configs.read_text() + "\n" + yaml.safe_dump(data_config))
    sys.path.insert(0, str(scratch))
    try:
        importlib.import_module("torchvision")
    except RuntimeError as err:  # a CUDA build of torchvision beside a CPU torch: its C operators do not load
        if "torchvision::" not in str(err):
            raise
        print(f"note: torchvision's C operators do not load ({str(err).splitlines()[-1]}); going on without them "
              f"(the loader uses its Python image functions only)")
        for name in [m for m in sys.modules if m.startswith("torchvision")]:
            del sys.modules[name]
        sys.modules["torchvision._meta_registrations"] = types.ModuleType("torchvision._meta_registrations")
    except ImportError as err:
        sys.exit(f"the official loader needs {err.name}: pip install lmdb torchvision (the torchvision of your torch)")
    from vint_train.data.vint_dataset import ViNT_Dataset
    return ViNT_Dataset


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--visualnav", type=Path, required=True, help="a visualnav-transformer checkout")
    ap.add_argument("--data", type=Path, required=True, help="an rvn-gen dataset (expert)")
    ap.add_argument("--split", default="train", choices=["train", "test"])
    ap.add_argument("--context-size", type=int, default=3, help="NoMaD's official config: 3")
    ap.add_argument("--len-traj-pred", type=int, default=8, help="NoMaD's official config: 8")
    ap.add_argument("--image-size", type=int, nargs=2, default=[96, 96], metavar=("W", "H"))
    ap.add_argument("--max-goal", type=int, default=20, help="the official distance.max_dist_cat")
    ap.add_argument("--every", type=int, default=25, help="compare the context frames of every N-th sample")
    args = ap.parse_args()
    data = args.data.expanduser().resolve()
    config_file = data / "data_config.yaml"
    if not config_file.is_file():
        sys.exit(f"--data {data}: no data_config.yaml; give a dataset rvn-gen wrote")
    data_config = yaml.safe_load(config_file.read_text())
    name = next(iter(data_config))
    split = data / "data_splits" / name / args.split
    if not (split / "traj_names.txt").is_file():
        sys.exit(f"--data {data}: no {split.relative_to(data)}/traj_names.txt")

    import torch

    from rvn_il.data import make_dataset

    C, P, size = args.context_size, args.len_traj_pred, tuple(args.image_size)
    with tempfile.TemporaryDirectory(prefix="rvn_official_") as tmp:
        scratch = Path(tmp)
        ViNT_Dataset = official_dataset_class(args.visualnav.expanduser(), data_config, scratch)
        shutil.copytree(split, scratch / "split")
        t0 = time.perf_counter()
        # the official config's distance (0..max, negative mining) and action (3..max) ranges, waypoint_spacing 1
        off = ViNT_Dataset(str(data), str(scratch / "split"), name, size, 1, 0, args.max_goal, 3, args.max_goal, True,
                           P, False, C, normalize=True)
        t1 = time.perf_counter()
        rvn = make_dataset(data, {"context_size": C, "len_traj_pred": P, "image_size": list(size)},
                           {"split": args.split, "crop": "official", "cache_dir": str(scratch / "cache"),
                            "progress": False, "goal_offset": (1, args.max_goal)})
        t2 = time.perf_counter()
        cache = rvn.cache
        traj = cache.traj_index[rvn.curr]
        rvn_index = {(cache.names[j], int(g - cache.traj_start[j])): n for n, (g, j) in enumerate(zip(rvn.curr, traj))}
        off_index = [(f, int(t)) for f, t, _ in off.index_to_data]
        only_off = set(off_index) - set(rvn_index)
        print(f"official loader: {len(off.traj_names)} trajectories, {len(off_index)} samples ({t1 - t0:.1f} s with "
              f"its LMDB cache); rvn-train: {len(cache.names)} trajectories, {len(rvn_index)} samples ({t2 - t1:.1f} s "
              f"with its packed cache)")
        print(f"  samples the official loader has and rvn-train not: {len(only_off)}; rvn-train's beyond the official "
              f"ones: {len(set(rvn_index) - set(off_index))} (it keeps each trajectory's last len_traj_pred frames, "
              f"its waypoints padded with the last pose)")
        wp, goal, frames = [], [], []
        for i, key in enumerate(off_index):
            if key in only_off:
                continue
            f, t = key
            b = rvn.get_batch([rvn_index[key]])
            actions, goal_pos = off._compute_actions(off._get_trajectory(f), t, t + int(b["distance"][0]))
            wp.append(np.abs(actions - b["actions"][0].numpy()).max())
            goal.append(np.abs(goal_pos - b["goal_pos"][0].numpy()).max())
            if i % args.every == 0:
                official = torch.cat([off._load_image(f, s) for s in range(t - C, t + 1)]).numpy()  # [3(C+1),H,W]
                ours = b["obs_image"][0].numpy().astype(np.float32).reshape(official.shape) / 255  # [C+1,3,H,W]
                frames.append(np.abs(official - ours).mean() * 255)
        print(f"  waypoint labels (normalised, {P} a sample): largest difference {max(wp):.1e}")
        print(f"  point-goal labels (the same goal offset): largest difference {max(goal):.1e}")
        print(f"  context frames ({len(frames)} samples x {C + 1} frames, data.crop=official): mean absolute "
              f"difference {np.mean(frames):.2f} of 255 (largest {max(frames):.2f}): PIL's bicubic resize in the "
              f"official loader, OpenCV's area resize in rvn-train's cache")


if __name__ == "__main__":
    main()
