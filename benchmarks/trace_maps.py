"""What rvn-eval's ``paths=true`` costs (`rvn_data.benchmark.traces`, `rvn_data.benchmark.trace_maps`): an episode
step with and without recording the agent's pose, a scene's map drawn from its episodes' traces, and a collision's
clip (its last 8 steps rendered again). The blind goal follower on the first val scenes (most of its episodes end in
a collision), at the camera size given."""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from rvn_data.benchmark.env import RVNEnv
from rvn_data.benchmark.policies import GoalFollowerPolicy
from rvn_data.benchmark.runner import run_episode
from rvn_data.benchmark.trace_maps import draw_clips, draw_maps
from rvn_data.benchmark.traces import write_trace
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.render import CameraConfig


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--per-scene", type=int, default=12)
    ap.add_argument("--pairs", type=int, default=5, help="timed passes with and without the trace, alternating")
    ap.add_argument("--size", type=int, default=64, help="camera width and height")
    ap.add_argument("--backend", choices=("auto", "gl", "raycast"), default="raycast")
    args = ap.parse_args(argv)
    camera = {"width": args.size, "height": args.size}
    with tempfile.TemporaryDirectory() as tmp:
        env = RVNEnv(mode="eval", split="val", scenes={"num_scenes": args.scenes}, per_scene=args.per_scene,
                     episodes={"n_goals": 4, "dir": str(Path(tmp) / "episodes")}, camera=camera,
                     renderer={"backend": args.backend}, cache_dir=str(Path(tmp) / "cache"))
        policy = GoalFollowerPolicy()
        policy.bind(env)
        n = args.scenes * args.per_scene
        run_episode(env, policy, 0, "warm-up", trace=True)
        timings = {}
        for trace in (False, True) * args.pairs:  # alternating: the machine's drift falls on both
            t0, steps, records = time.perf_counter(), 0, []
            for k in range(n):
                rec = run_episode(env, policy, k, "goal follower", trace=trace)
                steps += rec["steps"]
                records.append(rec)
            timings.setdefault(trace, []).append((time.perf_counter() - t0) / steps)
        env.close()
        plain, traced = min(timings[False]), min(timings[True])
        ratios = sorted(b / a for a, b in zip(timings[False], timings[True]))
        print(f"episode step: {plain * 1e3:.3f} ms plain, {traced * 1e3:.3f} ms recording the trace (fastest of "
              f"{args.pairs} passes each; x{ratios[len(ratios) // 2]:.3f} the median pair; {steps} steps of {n} "
              f"episodes a pass, {args.size}x{args.size}, {args.backend})")
        out = Path(tmp) / "run"
        for rec in records:
            write_trace(out, rec, rec.pop("trace"))
        t0 = time.perf_counter()
        maps = draw_maps(out, {}, NavMeshSettings(), Path(tmp) / "cache")
        per_map = (time.perf_counter() - t0) / len(maps)
        hits = sum(r["termination"] == "collision" for r in records)
        t0 = time.perf_counter()
        clips = draw_clips(out, {}, NavMeshSettings(), CameraConfig(**camera), {"collision": hits}, args.backend, Path(tmp) / "cache")
        per_clip = (time.perf_counter() - t0) / max(len(clips), 1)
        print(f"maps: {per_map * 1e3:.0f} ms a scene ({len(maps)} scenes, {args.per_scene} episodes each, navmesh "
              f"read from the cache root); clips: {per_clip * 1e3:.0f} ms a collision ({len(clips)} of {n} episodes)")


if __name__ == "__main__":
    main()
