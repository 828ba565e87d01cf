"""rvn-rl's envs side by side, phase by phase (issue 32's RL row): for each count in ``--processes``, that many
processes each step a `BatchEnv` of ``--envs`` envs of their own (rvn-rl's env settings: ``--size``² RGB, renderer
``--renderer``, ``--scenes`` train scenes, goal pool 64, scene prefetch, over a cache root filled first) with random
actions, started together, no learner and no main process gathering their observations. Each batched step is split
into the envs' state steps (simulator, collision, rewards, resets and scene switches: of them the switches, and of
those the renderer made for the new scene, its meshes uploaded), rendering (`render_views`: one call for the
process's envs) and the rest of the observations (goal vectors, batching), and the slowest step likewise, and how
busy the machine's cores were meanwhile (/proc/stat: the processes' scene-prefetch helpers included). Prints, for each count, the
env steps/s of all processes together and per process, each phase's mean ms a batched step (means add up to the
rate; the step's median and 90th percentile show the stalls) and its ratio to the first count's.

Why: on the fifth GPU run (docs/results/2026-12-04_gpu5) rvn-rl's envs alone gave 2,861 env steps/s in 15 worker
processes of 2 envs (191 a worker), 3,139 in 4 of 8 (785 a worker) and 1,007 in one of 2 (median batched step
1.0 ms): a worker's rate fell x5 from one worker to 15, and the envs alone are the bound of scale=small's 3,000 once
the act and the update are hidden. The phase that grows with the count is what the processes share (rendering: the
GPU's contexts, or the cores for software GL and ray casting; the state steps: the cores, with the prefetch helpers);
if none grows and the processes together beat the same envs as rvn-rl steps them (each count but 1 is also run
through `vec_procs.make_envs`: worker processes whose observations one process gathers), that process (the workers'
pipes, gathering the observations) is the bound.
Run: python benchmarks/rl_env_phases.py [--processes 1 4 15] [--envs 2] [--seconds 4] [--warm 5] [--renderer auto]
"""
from __future__ import annotations

import argparse
import itertools
import multiprocessing as mp
import os
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

PHASES = ("state", "render", "observe")  # besides the whole batched step; state holds the two below
SWITCH = ("switch", "upload")  # scene switches (`CachedSceneEnv._switch_to`), and the renderer made in them


def plan_and_settings(args, cache_dir: str, workers: int = 0) -> tuple[SimpleNamespace, dict]:
    """node.py's RL plan for these envs (``args.envs`` in this process, or in each of ``workers`` worker processes,
    over ``cache_dir``) and its row settings (scale=small's sizes): what `node_rl_runs.rl_args` turns into
    benchmarks/rl.py's arguments (`rl.overrides`) and `node_rl_runs.fill_scene_caches` fills the cache root for."""
    import node_rl_runs

    plan = SimpleNamespace(rl_envs=max(1, workers) * args.envs, rl_workers=workers, rl_scenes=args.scenes, rl_threads=1,
                           rl_cache=cache_dir, cpus=max(1, min(os.cpu_count() or 1, 16)))
    steps = getattr(args, "scene_switch_steps", 0)  # Habitat's scene switches with it, else rvn-rl's default
    habitat = {**node_rl_runs.HABITAT_SWITCH, "scene_switch_steps": steps} if steps else {}
    return plan, dict(size=args.size, backbone="resnet18", num_steps=64, ppo_epoch=4, mini_batches=1,
                      renderer=args.renderer, **habitat)


def overrides(args, cache_dir: str, workers: int = 0) -> list[str]:
    """rvn-rl's overrides for these envs, as node.py's RL rows make them (`node_rl_runs.rl_args`, `rl.overrides`)."""
    import node_rl_runs
    import rl as rl_bench

    return rl_bench.overrides(node_rl_runs.rl_args(*plan_and_settings(args, cache_dir, workers), updates=1),
                              os.path.join(cache_dir, "run"))


def warm_up(envs, rng: np.random.Generator, seconds: float) -> None:
    """10 batched steps of random actions, and on until ``seconds`` have passed (every env's prefetch helper started)."""
    t = time.perf_counter()
    for k in itertools.count():
        if k >= 10 and time.perf_counter() - t >= seconds:
            break
        envs.step(rng.integers(0, 4, envs.num_envs))


def worker(args, cache_dir: str, index: int, threads: int, barrier, results) -> None:
    """One process's `BatchEnv` (envs ``index * args.envs`` on, as `ProcessBatchEnv`'s worker ``index``), timed
    phase by phase for ``args.seconds`` after ``args.warm`` seconds (at least 10 batched steps) and the barrier."""
    from rvn_data.worker_threads import settle_worker_threads

    settle_worker_threads(threads)
    from rvn_data.benchmark.episodes_source import SceneSlot
    from rvn_rl import vec_env
    from rvn_rl.cli import compose

    cfg = compose(overrides(args, cache_dir))
    spent = dict.fromkeys(PHASES + SWITCH, 0.0)

    def timed(fn, phase: str):  # ``fn`` whose time adds to ``phase``; patched in this process only
        def call(*a, **k):
            t = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                spent[phase] += time.perf_counter() - t
        return call
    vec_env.render_views = timed(vec_env.render_views, "render")
    SceneSlot.with_renderer = timed(SceneSlot.with_renderer, "upload")
    envs = vec_env.BatchEnv(cfg.env_kwargs(), args.envs, seed=cfg.seed, scene_cache=cfg.env.scene_cache,
                            index_offset=index * args.envs, prefetch=cfg.env.prefetch_scenes)
    envs._observe = timed(envs._observe, "observe")
    def switches(env):  # a reset that loads another scene (one that keeps its scene returns at once: not counted)
        real, timed_real = env._switch_to, timed(env._switch_to, "switch")
        return lambda pos: real(pos) if env._scene is not None and env._scene.pos == pos else timed_real(pos)
    for env in envs.envs:
        env._switch_to = switches(env)
    rng = np.random.default_rng(index)
    rows = []
    try:
        envs.reset()
        warm_up(envs, rng, args.warm)
        barrier.wait()
        start = time.perf_counter()
        while time.perf_counter() - start < args.seconds:
            spent.update(dict.fromkeys(PHASES + SWITCH, 0.0))
            t = time.perf_counter()
            envs.step(rng.integers(0, 4, args.envs))
            step = time.perf_counter() - t
            # state: all but the observations; observe: the observations but the rendering
            rows.append((step, step - spent["observe"], spent["render"], spent["observe"] - spent["render"],
                         spent["switch"], spent["upload"]))
        results.put((index, time.perf_counter() - start, rows))
    finally:
        envs.close()


def cpu_times() -> tuple[float, float] | None:
    """(busy, all) jiffies of every core since boot (Linux's /proc/stat), else None."""
    try:
        with open("/proc/stat") as f:
            fields = [float(x) for x in f.readline().split()[1:]]
    except (OSError, ValueError):
        return None
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0.0)  # idle and iowait
    return sum(fields) - idle, sum(fields)


def busy_share(before, after) -> float | None:
    """The cores' busy share between two `cpu_times` readings (None where /proc/stat could not be read)."""
    return None if before is None or after is None else (after[0] - before[0]) / max(after[1] - before[1], 1)


def measure(args, processes: int, cache_dir: str) -> dict:
    """``processes`` workers started together; env steps/s together and per process, phases' medians (ms)."""
    from rvn_data.worker_threads import threads_per_worker, worker_threads

    ctx = mp.get_context("spawn")
    barrier, results = ctx.Barrier(processes + 1), ctx.Queue()
    threads = threads_per_worker(processes)
    with worker_threads(threads):
        procs = [ctx.Process(target=worker, args=(args, cache_dir, i, threads, barrier, results), daemon=True)
                 for i in range(processes)]
        for p in procs:
            p.start()
    barrier.wait(timeout=900)  # with the workers: their timed window starts
    before = cpu_times()  # the node's cores while they step, their scene-prefetch helpers included
    time.sleep(args.seconds)
    after = cpu_times()
    got = [results.get(timeout=600) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    if any(p.exitcode for p in procs):
        raise SystemExit(f"rl_env_phases: a worker failed (exit codes {[p.exitcode for p in procs]})")
    rates = [len(rows) * args.envs / seconds for _, seconds, rows in got]
    steps = np.array([r for _, _, rows in got for r in rows]) * 1e3
    slowest = steps[np.argmax(steps[:, 0])]
    return {"processes": processes, "together": sum(rates), "per_process": sum(rates) / processes,
            "mean": dict(zip(("step", *PHASES, *SWITCH), steps.mean(axis=0))),
            "slowest": dict(zip(("step", *PHASES, *SWITCH), slowest)),
            "switching": float(np.mean(steps[:, 4] > 0)),
            "cpu_busy": busy_share(before, after),
            "median_step": float(np.median(steps[:, 0])), "p90_step": float(np.percentile(steps[:, 0], 90)),
            "steps": len(steps)}


def gathered(args, processes: int, cache_dir: str) -> tuple[float, float | None]:
    """The same envs as rvn-rl steps them (`vec_procs.make_envs`: ``processes`` worker processes of ``args.envs`` envs
    each, their observations gathered by this process every batched step), random actions, after the same warm-up:
    env steps/s and the machine's cores' busy share."""
    from rvn_rl.cli import compose
    from rvn_rl.vec_procs import make_envs

    cfg = compose(overrides(args, cache_dir, processes))
    envs = make_envs(cfg.env_kwargs(), cfg.env, seed=cfg.seed)
    rng = np.random.default_rng(0)
    try:
        envs.reset()
        warm_up(envs, rng, args.warm)
        before, n, t = cpu_times(), 0, time.perf_counter()
        while time.perf_counter() - t < args.seconds:
            envs.step(rng.integers(0, 4, envs.num_envs))
            n += 1
        rate, after = n * envs.num_envs / (time.perf_counter() - t), cpu_times()
    finally:
        envs.close()
    return rate, busy_share(before, after)


def fill(args, cache_dir: str) -> float:
    """The scenes' navmeshes and goal pools made into ``cache_dir`` first (node.py's RL rows' way); seconds taken."""
    import node_rl_runs

    t = time.perf_counter()
    node_rl_runs.fill_scene_caches(*plan_and_settings(args, cache_dir), cache_dir)
    return time.perf_counter() - t


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cpus = os.cpu_count() or 1
    p.add_argument("--processes", type=int, nargs="+", default=sorted({1, max(1, cpus - 1)}))
    p.add_argument("--envs", type=int, default=2, help="envs a process (rvn-rl on the node: 2 a worker)")
    p.add_argument("--seconds", type=float, default=4.0, help="timed seconds a count")
    p.add_argument("--warm", type=float, default=5.0,
                   help="seconds stepped before the timed ones (each env's scene-prefetch helper starts at its first "
                        "scene and took ~1.3 s to its first prepared scene on the development CPU)")
    p.add_argument("--scenes", type=int, default=200)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--renderer", default="auto", choices=("auto", "gl", "raycast"))
    p.add_argument("--scene-switch-steps", type=int, default=0,
                   help="env.scene_switch_steps with env.scene_switch_every=0: an env draws another scene at its first "
                        "reset after ~this many steps in one (Habitat's max_scene_repeat_steps, 10000 there; default 0: "
                        "every 8 resets, rvn-rl's default: ~200 steps of random actions)")
    p.add_argument("--cache-dir", default=None,
                   help="the cache root, filled first and kept (default: a temporary one): runs that share it fill it once")
    args = p.parse_args(argv)
    for key in ("envs", "scenes", "size"):
        if getattr(args, key) < 1:
            p.error(f"--{key}={getattr(args, key)} must be >= 1")
    if min(args.processes) < 1 or args.seconds <= 0 or args.warm < 0 or args.scene_switch_steps < 0:
        p.error("--processes must be >= 1, --seconds > 0, --warm >= 0 and --scene-switch-steps >= 0")
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache_dir or tmp  # filled first either way (a filled root is only read: seconds)
        print(f"cache root filled ({args.scenes} scenes' navmeshes and goal pools) in {fill(args, cache):.0f} s",
              flush=True)
        from rvn_rl.settings import EnvSettings

        switch = (f"a scene switch at the first reset after ~{args.scene_switch_steps} steps in one" if
                  args.scene_switch_steps else f"a scene switch every {EnvSettings.scene_switch_every} resets")
        print(f"rvn-rl's envs, {args.envs} a process, {args.size}² RGB, renderer={args.renderer}, {args.scenes} train "
              f"scenes, {switch}, random actions, {args.seconds:g} s each ({cpus} CPUs):")
        first = None
        for n in args.processes:
            m = measure(args, n, cache)
            first = first or m
            mean = m["mean"]
            ratios = ", ".join(f"{k} x{mean[k] / max(first['mean'][k], 1e-9):.2f}" for k in ("step", *PHASES))
            print(f"  {n:>3} process(es): {m['together']:8.0f} env steps/s together, {m['per_process']:6.0f} a "
                  f"process; a batched step's mean {mean['step']:.2f} ms (median {m['median_step']:.2f}, 90th "
                  f"{m['p90_step']:.2f}): state steps {mean['state']:.2f}, rendering {mean['render']:.2f}, "
                  f"observations {mean['observe']:.2f} ms ({m['steps']} steps); against {first['processes']}: "
                  f"{ratios}", flush=True)
            if m["cpu_busy"] is not None:
                print(f"      the machine's cores {100 * m['cpu_busy']:.0f}% busy while they stepped", flush=True)
            slow = m["slowest"]
            print(f"      scene switches in {100 * m['switching']:.1f}% of the steps: {mean['switch']:.2f} ms a step "
                  f"on average (the renderer made {mean['upload']:.2f}); the slowest step {slow['step']:.0f} ms: "
                  f"state steps {slow['state']:.0f} (switches {slow['switch']:.0f}, renderer {slow['upload']:.0f}), "
                  f"rendering {slow['render']:.0f}, observations {slow['observe']:.0f}", flush=True)
            if n > 1 or len(args.processes) == 1:
                rate, busy = gathered(args, n, cache)
                print(f"      as rvn-rl steps them ({n} worker processes, one process gathering their observations "
                      f"each batched step): {rate:.0f} env steps/s, x{rate / m['together']:.2f} the processes on "
                      f"their own" + ("" if busy is None else f"; cores {100 * busy:.0f}% busy"), flush=True)


if __name__ == "__main__":
    main()
