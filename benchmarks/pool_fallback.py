"""How often a train-mode goal draw finds no goal of the scene's pool in range (`env.goal_pool`), and what it then
costs: the draw falls back to a fresh uniform goal, two geodesic distance fields solved in the env's own thread (one
from the agent, one from the new goal) in the middle of a batched step.

A reset draws a goal from a random start; a trained policy that reaches a goal draws the next one where it stands,
at a pool goal. Both are counted per scene: the share of random starts, and of the pool's goals themselves, from which
no other pool goal lies in the benchmark's range [d_min, d_max] of geodesic distance. Scenes are read through the
cache root (``--cache-dir``: their navmeshes and pools kept there, as a long run's later visits read them).
Run: python benchmarks/pool_fallback.py [--scenes 40 | --scene SPEC ...] [--goals 64] [--starts 100] [--cache-dir DIR]
"""
from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np


def scene_fallbacks(config, slot, starts: int, rng: np.random.Generator) -> tuple[int, int, int, float]:
    """(pool goals with no other in range, pool goals, starts with none in range, a fallback's ms) of one scene."""
    from rvn_data.benchmark.episodes import sample_goal, sample_start
    from rvn_data.benchmark.episodes_source import SceneSlot

    s = config.episodes
    scene = SceneSlot.load(config, slot, 0)
    sampler = scene.goal_sampler(config)
    at_goal = sum(sampler.sample(np.asarray(g), rng, s.d_min, s.d_max) is None for g in sampler.goals)
    at_start = sum(sampler.sample(sample_start(scene.navmesh, rng)[0], rng, s.d_min, s.d_max) is None
                   for _ in range(starts))
    source = sample_start(scene.navmesh, rng)[0]
    t = time.perf_counter()  # the fallback's path: `SceneSlot.draw_goal`, then `RVNEnv._next_goal`'s field
    found = sample_goal(scene.navmesh, scene.navmesh.distance_field(source), rng, s.d_min, s.d_max, s.max_tries)
    if found is not None:
        scene.navmesh.distance_field(np.asarray(found[0], np.float64))
    return at_goal, len(sampler.goals), at_start, 1e3 * (time.perf_counter() - t)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", type=int, default=40, help="procedural train scenes (the first N)")
    p.add_argument("--scene", action="append", default=None, metavar="SPEC",
                   help="a scene spec or mesh file instead (repeatable), e.g. ../shared/scenes/dream_apartment.glb")
    p.add_argument("--goals", type=int, default=64, help="pool size (env.goal_pool)")
    p.add_argument("--starts", type=int, default=100, help="random starts a scene")
    p.add_argument("--cache-dir", default=None, help="cache root (default: a temporary one, pools built)")
    args = p.parse_args(argv)
    if min(args.scenes, args.goals, args.starts) < 1:
        p.error("--scenes, --goals and --starts must be positive")

    from rvn_data.benchmark.episodes_source import EnvConfig
    from rvn_data.scenes import SceneError

    with tempfile.TemporaryDirectory() as tmp:
        scenes = {"scene_specs": args.scene} if args.scene else {
            "scenes": {"source": "procedural", "num_scenes": args.scenes}}
        config = EnvConfig.from_kwargs(mode="train", split="train", goal_pool=args.goals,
                                       cache_dir=args.cache_dir or tmp, **scenes)
        rng = np.random.default_rng(0)
        try:
            rows = [scene_fallbacks(config, slot, args.starts, rng) for slot in config.scene_slots()]
        except (SceneError, ValueError, OSError) as e:  # a scene that does not load: named, no traceback
            raise SystemExit(f"pool_fallback.py: {e}") from None
    at_goal, goals, at_start = (sum(r[k] for r in rows) for k in range(3))
    starts, ms = args.starts * len(rows), [r[3] for r in rows]
    s = config.episodes
    given = "scene(s) given" if args.scene else "procedural train scenes"
    print(f"{len(rows)} {given}, pool of {args.goals}, goals {s.d_min:g}-{s.d_max:g} m apart: no pool goal in range "
          f"at a pool goal (a reached goal's next draw) {at_goal}/{goals} ({100 * at_goal / goals:.1f}%), at a random "
          f"start (a reset's draw) {at_start}/{starts} ({100 * at_start / starts:.1f}%), worst scene "
          f"{max(100 * r[2] / args.starts for r in rows):.0f}% of its starts")
    print(f"a fallback (two fresh distance fields in the env's thread): median {np.median(ms):.1f} ms, "
          f"slowest {max(ms):.1f} ms over {len(ms)} scenes")


if __name__ == "__main__":
    main()
