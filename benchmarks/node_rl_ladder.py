"""node.py's CUDA RL rows past the plain ones (node_rl.py): the env workers' layout, then a ladder of levers.

Why the layout first. On the first GPU run one view a GL call gave 4,051 frames/s in one process and ~2,400 in 2 or
16 processes together (docs/results/2026-11-27_gpu): the processes' calls take turns on the GPU, ~0.4 ms each. An
rvn-rl worker renders its envs' views in one call a batched step, so scale=small's 15 workers of 2 envs make 15 calls
a step: >= ~6.3 ms, <= ~4,800 env steps/s for 30 envs however fast the rest. The fifth run's envs alone agree: a
median batched step of 6.7 ms in 15 x 2 (1.0 ms in one worker of 2), 10.4 ms in 15 x 4, and 5.2 ms for 32 envs in
4 x 8 (6,150 env steps/s at that median; its mean was twice it, the helpers' start-up in its window, since left out).
Fewer, larger workers make fewer calls of more views; each worker then steps more envs on its core (~0.12 ms an
env's state step, ~0.01 its observation: a worker of 10 envs on the 2-core development CPU, `rl_env_phases.py`). So
the envs-alone rows ``rl_envs_<W>x<E>`` (`layouts`) first time every layout of 2-10 envs a worker after the warm-up:
if the calls bound the envs, the fewest workers whose own CPU work stays below the GPU's turns win. Then
``rl_workers_<W>`` runs rvn-rl in the fastest of them, and the ladder's base is the faster of that and the rl row.
"""
from __future__ import annotations

import math
from collections.abc import Iterator

import node_rl_runs as runs
from node_rows import failed_row

# the ladder's settings (`rl.overrides`' names) as their labels name them
LEVERS = {"graph_act": "train.graph_act=true", "overlap": "train.overlap=true",
          "recompute": "ppo.recompute_advantages=true", "double_buffered": "train.double_buffered=true",
          "compile": "train.compile=true", "scene_switch_steps": runs.HABITAT_LABEL}


def guarded(key: str, what: str, run) -> dict:
    """``run()``'s row, or where it raised, the row ``key`` naming its error (traceback to stderr), so that the rows
    after it still run: none of these paths has run on a GPU before its lease, and node.py ends a group at the first
    exception, which would lose every rung after a failing one."""
    try:
        return run()
    except Exception as e:
        return failed_row(5, key, f"{runs.RL_LABEL}{what}", "env steps/s", e)


def fat_workers(envs: int) -> int:
    """The workers of ``rl_workers_<W>``: the smallest divisor of ``envs`` at least sqrt(envs), and 2 or more where
    there are 2 envs (two halves for train.double_buffered): 30 envs -> 6 workers of 5, 32 -> 8 of 4, 16 -> 4 of 4."""
    root = math.isqrt(max(envs, 1) - 1) + 1  # ceil(sqrt(envs))
    return min(envs, max(2, next(w for w in range(root, envs + 1) if envs % w == 0)))


MAX_ENVS_A_WORKER = 10  # the layouts' largest worker: 3 GL calls a batched step for 30 envs; its state steps take
# 1.15 ms a batched step, its observations 0.12 (`rl_env_phases.py --processes 1 --envs 10`, 128², development CPU)


def layouts(envs: int, workers: int) -> list[tuple[int, int]]:
    """(workers, envs a worker) of ``envs`` envs in at most ``workers`` workers of 2 to `MAX_ENVS_A_WORKER` envs each,
    most workers first: 30 envs, 15 workers -> 15 x 2, 10 x 3, 6 x 5, 5 x 6, 3 x 10."""
    return [(w, envs // w) for w in range(workers, 0, -1) if envs % w == 0 and 2 <= envs // w <= MAX_ENVS_A_WORKER]


def layout_rows(plan, small: dict, plain: dict) -> Iterator[dict]:
    """Unless node.py --skip rl_layouts, the envs alone in each of `layouts` after ``plan.rl_warm_seconds``; then
    ``rl_workers_<W>``: the rl row's run with its envs in the workers of the fastest of those layouts (on a tie the
    one with more workers; `fat_workers` where the layouts were skipped or all failed), naming its ratio to rl. No
    such row where that is the rl row's own layout: fewer workers did not pay. Returns the settings the ladder builds
    on: the faster of the rl runs'."""
    w = fat_workers(plan.rl_envs)
    if "rl_layouts" not in plan.skip:
        timed = []
        for workers, per_worker in layouts(plan.rl_envs, plan.rl_workers):
            row = guarded(f"rl_envs_{workers}x{per_worker}", f"envs alone, {workers} x {per_worker}",
                          lambda: runs.rl_envs_row(plan, small, workers=workers, per_worker=per_worker))
            yield row
            if row["value"] is not None:
                timed.append((row["value"], workers))
        if timed:
            w = max(timed)[1]
    if w == plan.rl_workers:
        return small
    key, what = f"rl_workers_{w}", f"scale=small, env.workers={w}"
    fewer = guarded(key, what, lambda: runs.rl_row(plan, key, what, {**small, "workers": w}, "rl", "",
                                                   against=plain["value"]))
    yield fewer
    faster = fewer["value"] is not None and (plain["value"] is None or fewer["value"] > plain["value"])
    return {**small, "workers": w} if faster else small


def graph_act_rows(plan, base: dict, against: float) -> Iterator[dict]:
    """A ladder of rows from ``base`` (scale=small's settings, with `layout_rows`' faster layout), each adding one
    lever to the row before it and naming its ratio to rl: train.graph_act=true (``rl_graph_act``: each act one CUDA
    graph's replay, where the fourth GPU run's act was ~7.9 ms of host launches against 1.8 ms of kernels); the update
    overlapped (``rl_graph_act_overlap``: train.overlap=true and ppo.recompute_advantages=true, as rl_overlap); the
    collection double-buffered (``..._double_buffered``: one half of the env workers steps while the graphed act runs
    for the other); Habitat's scene switches (``..._scene_steps``, `node_rl_runs.HABITAT_SWITCH`: on the fifth run the
    envs alone took a batched step of 10.5 ms on average, 30 envs at 2,861 env steps/s, against a median of 6.7 ms,
    the helpers' start-up and the scene switches in the difference); last every lever, the learner's trunk compiled
    too (``rl_all_levers``: train.compile=true, reduce-overhead, an update x1.36 on the fifth run and less host time
    for the learner thread to take from the collection's for the GIL; ~50 s compiling: last, what a short lease
    loses). Each label names env.workers where ``base`` sets it; a rung that fails names its error (`guarded`) and the
    next one runs."""
    ladder, levers = [], {}
    layout = [f"env.workers={base['workers']}"] if "workers" in base else []
    for key, lever in (("graph_act", {"graph_act": True}), ("overlap", {"overlap": True, "recompute": True}),
                       ("double_buffered", {"double_buffered": True}), ("scene_steps", runs.HABITAT_SWITCH),
                       ("compile", {"compile": True})):
        ladder.append(key)
        levers = {**levers, **lever}
        name = "rl_all_levers" if key == "compile" else "rl_" + "_".join(ladder)
        what = ", ".join(["scale=small"] + layout + [LEVERS[k] for k in LEVERS if k in levers])
        settings = {**base, **levers}
        yield guarded(name, what, lambda: runs.rl_row(plan, name, what, settings, "rl", "", against=against))
