"""What checking a dataset costs (issue 35 item 4): rvn-gen checks every trajectory it resumes and
rvn-train every trajectory it trains on (`rvn_data.dataset.verify`: pose file, sidecar, each frame's
JPEG header size and end marker, depth sidecar). Prints the time for the whole dataset, per
trajectory and per frame, and what a full decode of every frame would cost instead; then what rvn-train's
start costs when the packed cache of the dataset is current (its preflight then only loads the poses and
compares the cache's fingerprint, a stat of every file: `rvn_il.train.preflight.packed_current`), against the
frame check it replaces.

    python benchmarks/verify.py [--scenes 4] [--per-scene 10] [--size 256] [--repeats 5]

The dataset is generated once into a temporary folder (rvn-gen's default: 4 train scenes x 10
trajectories at 256x256); the figures are the median of ``--repeats`` passes over it (files in the
page cache, as on a resume right after the run that wrote them).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import statistics
import tempfile
import time
from pathlib import Path

from rvn_data.config import load_config
from rvn_data.dataset.verify import Expect, damaged
from rvn_data.gen.run import generate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--per-scene", type=int, default=10)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "expert"
        cfg = load_config("gen", [f"out_dir={out}", "progress=false", f"scenes.num_scenes={args.scenes}",
                                  f"trajectories_per_scene={args.per_scene}", f"camera.width={args.size}",
                                  f"camera.height={args.size}"])
        with contextlib.redirect_stdout(io.StringIO()):
            generate(cfg)
        names = sorted(p.name for p in out.iterdir() if (p / "traj_data.pkl").is_file())
        frames = sum(len(list((out / n).glob("*.jpg"))) for n in names)
        expect = Expect.of_dataset(out)

        def timed(fn) -> float:
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                fn()
                times.append(time.perf_counter() - t0)
            return statistics.median(times)

        check = timed(lambda: damaged(out, names, expect))
        import cv2

        decode = timed(lambda: [cv2.imread(str(p)) for n in names for p in (out / n).glob("*.jpg")])
        from rvn_data.dataset.reader import load_gnm
        from rvn_il.data.cache import cache_state, ensure_cache

        ensure_cache(load_gnm(out, "all"), (64, 64), "aspect", Path(tmp) / "packed", progress=False)
        current = timed(lambda: cache_state(load_gnm(out, "all"), (64, 64), "aspect", Path(tmp) / "packed")[2])
        assert cache_state(load_gnm(out, "all"), (64, 64), "aspect", Path(tmp) / "packed")[2]
    print(f"dataset: {len(names)} trajectories, {frames} frames of {args.size}x{args.size}")
    print(f"check (verify.damaged): {check * 1e3:.1f} ms in all, {check / len(names) * 1e3:.2f} ms per trajectory, "
          f"{check / frames * 1e6:.1f} us per frame")
    print(f"a full decode of every frame instead (cv2.imread): {decode * 1e3:.0f} ms ({decode / max(check, 1e-9):.0f}x)")
    print(f"at paper scale (~14M frames) the check would take about {check / frames * 14e6 / 60:.1f} min")
    print(f"rvn-train's start with a current packed cache (poses + fingerprint, no frame read): {current * 1e3:.1f} ms, "
          f"{current / frames * 1e6:.1f} us per frame: {check / max(current, 1e-9):.1f}x less than the frame check "
          f"(paper scale: about {current / frames * 14e6 / 60:.1f} min)")


if __name__ == "__main__":
    main()
