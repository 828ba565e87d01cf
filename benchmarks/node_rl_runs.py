"""How node.py's RL rows run (rvn-rl's trainer, or its envs alone) and what each row says: the rows' settings as
benchmarks/rl.py's arguments (`rl_args`), the scenes' caches filled before the rows (`fill_scene_caches`), one row of
rvn-rl collection + learning (`rl_row`) and one of the envs alone (`rl_envs_row`). node_rl.py orders the rows and
node_rl_ladder.py its ladder; node_rows.py holds the other groups, whose `row` these share."""
from __future__ import annotations

import json
import math
import multiprocessing as mp
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from types import SimpleNamespace

import numpy as np

from node_report import GpuBusy
from node_rows import row

RL_LABEL = "rvn-rl PPO collection + learning, "  # the label of each row that trains, before its settings
# Habitat's scene switches (max_scene_repeat_steps 10,000, max_scene_repeat_episodes off) instead of every 8 resets
HABITAT_SWITCH = {"scene_switch_steps": 10000, "scene_switch_every": 0}
HABITAT_LABEL = ", ".join(f"env.{k}={v}" for k, v in HABITAT_SWITCH.items())


def _keep_scene(config, slot) -> None:
    from rvn_data.benchmark.episodes_source import SceneSlot

    SceneSlot.prepared_parts(config, slot, True)  # written to the cache root; nothing sent back


def fill_scene_caches(plan, settings: dict, root: str) -> str:
    """The RL rows' scenes' navmeshes and goal pools of 64, made into the cache root ``root`` by ``plan.cpus``
    processes; what the rows' settings say about it."""
    import rl as rl_bench
    from rvn_data.benchmark.episodes_source import EnvConfig
    from rvn_rl.cli import compose

    args = rl_args(plan, settings, updates=1)
    args.cache_dir = root
    config = EnvConfig.from_kwargs(**compose(rl_bench.overrides(args, f"{root}/run")).env_kwargs())
    slots = config.scene_slots()
    t = time.perf_counter()
    with ProcessPoolExecutor(plan.cpus, mp_context=mp.get_context("spawn")) as pool:
        list(pool.map(_keep_scene, [config] * len(slots), slots))
    return (f"over a cache root holding the {len(slots)} scenes' navmeshes and goal pools (made by {plan.cpus} "
            f"processes in {time.perf_counter() - t:.0f} s before the rows: a long run after its first pass)")


def rl_args(plan, settings: dict, updates: int) -> SimpleNamespace:
    """benchmarks/rl.py's arguments (`rl.overrides`) for the RL rows: the plan's envs, workers and scenes, a goal pool
    of 64, ``settings`` (size, backbone, PPO; renderer, else auto; workers, else the plan's)."""
    return SimpleNamespace(**{"envs": plan.rl_envs, "workers": plan.rl_workers, "scenes": plan.rl_scenes,
                              "base_planes": 32, "threads": plan.rl_threads, "updates": updates, "goal_pool": 64,
                              "cache_dir": getattr(plan, "rl_cache", None), "renderer": "auto", **settings})


def skipped_rl_row(key: str, what: str, why: str) -> dict:
    """A row of `rl_row`'s kind left out, ``why`` in its place (its label without the device: nothing ran)."""
    return row(5, key, f"{RL_LABEL}{what}", "env steps/s", skipped=why)


def rl_row(plan, key: str, what: str, settings: dict, goal_key: str | None, baseline: str,
            against: float | None = None) -> dict:
    """rvn-rl's own loop (`rvn_rl.trainer.train`) with ``settings``; ``against``: the rl row's rate (float32, not
    compiled), whose ratio to this one the row names. A row in ``plan.skip`` (node.py --skip) is named as skipped."""
    if key in getattr(plan, "skip", ()):
        return skipped_rl_row(key, what, "left out by node.py --skip")
    import rl as rl_bench
    from rvn_rl.cli import compose
    from rvn_rl.trainer import train

    # overlapped, a run's last update has no collection beside it: one more, so that one update counts
    args = rl_args(plan, settings, updates=3 if settings.get("overlap") else 2)
    envs, workers = args.envs, args.workers
    counted = []  # (env steps, seconds, update's metrics) of the updates that count (`rl.steady_updates`)
    warm = plan.rl_warm_seconds  # a run's first seconds: its envs' scene-prefetch helpers starting
    with tempfile.TemporaryDirectory() as tmp, GpuBusy() as busy:
        out = f"{tmp}/run"
        train(compose(rl_bench.overrides(args, out)))
        rows = _metrics(out)
        if not warm:  # else this short run only times an update: all of it is warm-up
            counted += [_steps_seconds(r, envs) for r in rl_bench.steady_updates(rows)]
        left = plan.seconds - sum(s for _, s, _ in counted)
        if left > 0 and not plan.quick:
            args.updates += 1 + math.ceil((left + warm) / (_steps_seconds(rows[-1], envs)[1] or 1e-3))
            train(compose(rl_bench.overrides(args, out)))
            later = _metrics(out)[len(rows):]
            counted += [_steps_seconds(r, envs) for r in
                        rl_bench.steady_updates(later, warm, envs) or rl_bench.steady_updates(later)]
    steps, seconds = sum(n for n, _, _ in counted), sum(s for _, s, _ in counted)
    if against is not None:
        baseline = f"x{steps / seconds / against:.2f} the rl row's {against:.0f} (float32, not compiled)"
    profile = None
    if plan.profile:  # the learner's side of an update, without the envs (rl.learner_profile)
        from rvn_il.policies.policy import intra_op_threads

        with tempfile.TemporaryDirectory() as tmp, intra_op_threads(plan.rl_threads):
            profile = rl_bench.learner_profile(compose(rl_bench.overrides(args, f"{tmp}/run")),
                                               "cuda" if plan.cuda else "cpu")

    def share(k: str) -> float:  # time-weighted share of the counted updates' time
        return sum(s * r.get(k, float("nan")) for _, s, r in counted) / seconds

    return row(5, key, f"{RL_LABEL}{what} ({'cuda' if plan.cuda else 'cpu'})", "env steps/s",
               goal_key, steps / seconds,
               f"{args.size}² RGB, renderer={args.renderer}, {args.backbone} (base planes 32), "
               f"PPO rollouts of {args.num_steps} x {envs} envs, "
               f"{args.ppo_epoch} epochs x {args.mini_batches} mini-batches, {workers} env worker processes, "
               f"{plan.rl_scenes} train scenes, goal pool {args.goal_pool} {plan.rl_filled}, "
               f"{len(counted)} updates timed ({seconds:.1f} s) after a run's first {warm:g} s; time: "
               f"{'waiting for the envs' if settings.get('double_buffered') else 'envs stepping'} "
               f"{100 * share('time_envs'):.0f}%, "
               f"policy and storage {100 * (1 - share('time_envs') - share('time_learn')):.0f}%, "
               f"{'waiting for the PPO update' if settings.get('overlap') else 'PPO update'} "
               f"{100 * share('time_learn'):.0f}%", baseline, busy.share, profile=profile)


def rl_envs_row(plan, settings: dict, workers: int | None = None, prefetch: bool = True,
                 with_prefetch: float | None = None, goal_pool: int = 64, with_pool: float | None = None,
                 first_pass: bool = False, kept_caches: float | None = None, per_worker: int | None = None,
                 renderer: str | None = None, against: float | None = None) -> dict:
    """The rl row's envs alone (`rl.collection`: the same vec env and worker processes, random actions, no policy, no
    learner), so a slow rl row shows whether the envs or their sharing the node with the learner bound it. With
    ``workers`` (row ``rl_envs_<workers>``), that many worker processes with as many envs each as the rl row's: on the
    first GPU run an env step took ~30 ms in 15 workers against ~9 ms in 2 workers of the 2-core development CPU.
    ``prefetch``: env.prefetch_scenes (row ``rl_envs_no_prefetch`` without it, which names the ratio of
    ``with_prefetch``, the rate with it, to its own). ``goal_pool=0`` (row ``rl_envs_fresh_goals``, naming the ratio of
    ``with_pool``, the rate with the recipe's pool of 64, to its own): two Dijkstra solves a goal instead of the pool's
    64 at each scene a worker has not kept (on the 2-core development CPU, 200 scenes: ~500 env steps/s against ~410
    with the pool and prefetch). ``first_pass`` (row ``rl_envs_first_pass``, naming the ratio of ``kept_caches``, the
    rate over the kept caches, to its own): over an empty cache root, each scene's navmesh built and pool solved and
    smoothed at its first visit. Each row times two rollouts' batched steps and more until ``plan.seconds`` have passed
    (until the fourth GPU run, 128 steps, ~1 s on the node, held one stall or none). The settings give each batched
    step's median, 90th and 99th percentile and slowest: vectorised envs step together, so an env whose scene switch
    waits holds up the batch, in the tail. ``per_worker`` (row ``rl_envs_<workers>x<per_worker>``): that many envs in
    each worker, whose views a worker renders in one call; ``renderer`` (row ``rl_envs_<renderer>``): that renderer
    instead of auto's; both name the ratio of their rate to ``against``, the rl_envs row's. On the first GPU run GL with
    one view a call gave 4,051 frames/s in one process and 2,393 in 16 together, with 32 views a call 10,506 in 16
    (docs/results/2026-11-27_gpu): these rows ask whether that bounds the envs (on the fourth run 115 env steps/s a
    worker in 15 workers, against a median batched step of 1.4 ms for 2 envs in one)."""
    import rl as rl_bench
    from rvn_rl.cli import compose

    args = rl_args(plan, settings, updates=1)
    args.goal_pool = goal_pool
    if renderer is not None:
        args.renderer = renderer
    if first_pass:
        args.cache_dir = None  # the row's own <out_dir>/cache, empty
    if workers is not None:
        args.envs, args.workers = (per_worker or max(1, plan.rl_envs // plan.rl_workers)) * workers, workers
    extra = [] if prefetch else ["env.prefetch_scenes=false"]
    times: list[float] = []  # each batched step's seconds: a scene switch that waits shows in the top percentiles
    with tempfile.TemporaryDirectory() as tmp, GpuBusy() as busy:
        rate = rl_bench.collection(compose(rl_bench.overrides(args, f"{tmp}/run") + extra), 2 * args.num_steps, False,
                                   times, seconds=0.0 if plan.quick else plan.seconds,
                                   warm_seconds=plan.rl_warm_seconds)
    ms = 1e3 * np.percentile(times, [50, 90, 99, 100])
    ratio = "" if with_prefetch is None else f"; with env.prefetch_scenes (rl_envs): x{with_prefetch / rate:.2f} this"
    ratio += "" if with_pool is None else f"; with the goal pool of 64 (rl_envs): x{with_pool / rate:.2f} this"
    ratio += "" if kept_caches is None else f"; over the kept caches (rl_envs): x{kept_caches / rate:.2f} this"
    ratio += "" if against is None else f"; x{rate / against:.2f} the rl_envs row's {against:.0f}"
    caches = ("over an empty cache root (each scene's navmesh built and pool solved and smoothed at its first visit)"
              if first_pass else plan.rl_filled)
    return row(5, "rl_envs" + ("" if workers is None else f"_{workers}")
               + ("" if per_worker is None else f"x{per_worker}")
               + ("" if renderer is None else f"_{renderer}") + ("" if prefetch else "_no_prefetch")
               + ("" if goal_pool else "_fresh_goals") + ("_first_pass" if first_pass else ""),
               f"rvn-rl envs alone, scale=small's envs ({'cuda' if plan.cuda else 'cpu'})"
               + ("" if workers is None else f", {workers} worker(s)")
               + ("" if per_worker is None else f" x {per_worker} envs")
               + ("" if renderer is None else f", renderer={renderer}")
               + ("" if prefetch else ", env.prefetch_scenes=false")
               + ("" if goal_pool else ", env.goal_pool=0") + (", first pass over the scenes" if first_pass else ""),
               "env steps/s", None, rate,
               f"{args.size}² RGB, renderer={args.renderer}, {args.envs} envs in {args.workers} worker processes, "
               f"{plan.rl_scenes} train scenes, goal pool {args.goal_pool} {caches}, random actions, no policy or "
               "learner, "
               f"{len(times)} batched steps after 10 of warm-up and {plan.rl_warm_seconds:g} s more: "
               f"{rate / args.workers:.0f} env steps/s "
               f"per worker; batched step median {ms[0]:.1f} ms, 90th {ms[1]:.1f}, 99th {ms[2]:.1f}, "
               f"slowest {ms[3]:.0f}"
               f"{ratio}", gpu_busy=busy.share)


def _steps_seconds(update: dict, envs: int) -> tuple[float, float, dict]:
    """Env steps and seconds (`rl.update_seconds`) of one update of rvn-rl's metrics.jsonl, and the update's row."""
    import rl as rl_bench

    return update["rollout_steps"] * envs, rl_bench.update_seconds(update, envs), update


def _metrics(out: str) -> list[dict]:
    with open(f"{out}/metrics.jsonl") as f:
        return [json.loads(line) for line in f]
