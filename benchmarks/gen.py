"""rvn-gen throughput: end-to-end frames/s written (expert or negative, procedural default scenes,
256x256 JPEG) with 1 and 2 processes, and the share of time in setup (scene, navmesh,
renderer), planning (sampling, geodesics, A*, following), rendering, encoding and writing, and the
planning seconds per trajectory and per frame (issue 32: planning was 67 % of rvn-gen's time
on a 16-core GPU node).

    python benchmarks/gen.py [--scenes 4] [--per-scene 10] [--renderer auto] [--dataset expert]

Goals (issue 4): >= 200 frames/s per process, >= 1.7x with 2 processes. Wall time includes
process start-up and per-scene setup, as a user sees it. LP_NUM_THREADS=1 (unless set)
keeps Mesa's software GL on one core per process, so "per process" means one core.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import tempfile
from pathlib import Path

from rvn_data.config import load_config
from rvn_data.dataset.scene_job import TIMERS
from rvn_data.gen.run import generate


def run(out_dir: Path, overrides: list[str]):
    cfg = load_config("gen", [f"out_dir={out_dir}", "progress=false", *overrides])
    with contextlib.redirect_stdout(io.StringIO()):
        report = generate(cfg)
    if report.status:
        raise SystemExit(f"generation failed: {[r.error for r in report.results if r.error]}")
    return report


def timing(report) -> dict[str, float]:
    """Seconds per TIMERS phase, summed over the report's scenes (so over processes)."""
    return {k: sum(r.timing[k] for r in report.results) for k in TIMERS}


def backends(report) -> list[str]:
    """The renderer back-ends the report's scenes used."""
    return sorted({b for r in report.results for b in r.record["renderers"]})


def main() -> None:
    os.environ.setdefault("LP_NUM_THREADS", "1")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--per-scene", type=int, default=10)
    ap.add_argument("--renderer", default="auto")
    ap.add_argument("--dataset", default="expert", choices=["expert", "negative"])
    args = ap.parse_args()
    common = [f"scenes.num_scenes={args.scenes}", f"trajectories_per_scene={args.per_scene}",
              f"renderer={args.renderer}", "camera.width=256", "camera.height=256", f"dataset={args.dataset}"]
    with tempfile.TemporaryDirectory() as tmp:
        run(Path(tmp) / "warmup", ["scenes.num_scenes=1", "trajectories_per_scene=1", f"renderer={args.renderer}"])
        rates = {}
        for workers in (1, 2):
            rep = run(Path(tmp) / f"w{workers}", [*common, f"workers={workers}"])
            rates[workers] = rep.frames / rep.seconds
            phases = timing(rep)
            total = sum(phases.values())
            shares = ", ".join(f"{k} {100 * v / total:.0f}%" for k, v in phases.items())
            print(f"{workers} process{'es' if workers > 1 else ''}: {rep.frames} frames "
                  f"({sum(r.written for r in rep.results)} trajectories, {args.scenes} scenes) in {rep.seconds:.1f} s "
                  f"= {rates[workers]:.0f} frames/s; renderer {', '.join(backends(rep))}")
            print(f"  time share (summed over processes): {shares}")
            print("  per frame: " + ", ".join(f"{k} {1000 * v / rep.frames:.2f} ms" for k, v in phases.items()))
            trajectories = sum(r.written for r in rep.results)
            print(f"  planning (sampling, geodesics, A*, following): {phases['planning']:.2f} s summed = "
                  f"{1000 * phases['planning'] / trajectories:.1f} ms per trajectory, "
                  f"{1000 * phases['planning'] / rep.frames:.2f} ms per frame")
        print(f"speed-up with 2 processes: {rates[2] / rates[1]:.2f}x "
              f"(goals: >= 200 frames/s per process, >= 1.7x with 2)")


if __name__ == "__main__":
    main()
