"""An env's state step alone (issue 32's RL row): `RVNEnv.step_state` (the simulator's move with its collision test,
the geodesic distance to the goal, the reward, cost and ending, the step's info), no rendering, in train mode with
the goal pool, random actions. rvn-rl's workers step their envs so between renders: on the fifth GPU run a worker's
batched step of 2 envs took 1.0 ms alone, so a state step's tens of microseconds count, and more with more envs a
worker (node.py's layout rows). Prints the microseconds of a step that does not end its episode (median of
``--rounds`` rounds) and of a reset (the start and goal draws; the scene switches of every ``--switch-every`` resets
among ``--scenes`` scenes, which a worker's prefetch has prepared, are left out by keeping one scene), and the
episodes' summed return (the same figure before and after a change that should not change them).
Run: python benchmarks/env_state.py [--steps 5000] [--rounds 5] [--scene-index 3]
"""
from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=5000, help="steps a round")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--scene-index", type=int, default=3, help="the procedural train scene stepped")
    p.add_argument("--goal-pool", type=int, default=64)
    args = p.parse_args(argv)
    if min(args.steps, args.rounds) < 1 or args.scene_index < 0:
        p.error("--steps and --rounds must be positive, --scene-index not negative")

    from rvn_data.benchmark.env import RVNEnv

    with tempfile.TemporaryDirectory() as tmp:
        env = RVNEnv(mode="train", split="train", scenes={"first_scene": args.scene_index, "num_scenes": 1},
                     goal_pool=args.goal_pool, cache_dir=tmp, camera={"width": 64, "height": 64},
                     renderer={"backend": "raycast"})
        env.reset_state(seed=0)
        rng = np.random.default_rng(0)
        actions = rng.choice([0, 1, 1, 1, 2, 3], size=(args.rounds + 1, args.steps))  # STOP, forward x3, turns
        steps_us, resets_us, total = [], [], 0.0
        for k, round_actions in enumerate(actions):  # the first round warms up (pool built, kernels loaded)
            stepped, reset, n_steps, n_resets = 0.0, 0.0, 0, 0
            for a in round_actions:
                t = time.perf_counter()
                r, terminated, truncated, _ = env.step_state(int(a))
                dt = time.perf_counter() - t
                total += r if k else 0.0
                if terminated or truncated:
                    t = time.perf_counter()
                    env.reset_state()
                    reset += time.perf_counter() - t
                    n_resets += 1
                else:
                    stepped += dt
                    n_steps += 1
            if k:
                steps_us.append(1e6 * stepped / max(n_steps, 1))
                resets_us.append(1e6 * reset / max(n_resets, 1))
        env.close()
    print(f"RVNEnv.step_state, procedural:train/{args.scene_index}, goal pool {args.goal_pool}, random actions: "
          f"{np.median(steps_us):.1f} us a step (median of {args.rounds} rounds of {args.steps}; "
          f"{min(steps_us):.1f}-{max(steps_us):.1f}), a reset {np.median(resets_us):.0f} us; "
          f"episodes' return {total:.6f}")


if __name__ == "__main__":
    main()
