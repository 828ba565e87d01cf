"""The RL rows of benchmarks/node.py (issue 32's row 5) in the order they run: rvn-rl PPO collection + learning, as
rvn-rl's trainer runs it, and the envs alone (node_rl_runs.py runs each row; node_rl_ladder.py the layouts and the
ladder of levers on a GPU); the other groups are in node_rows.py."""
from __future__ import annotations

import tempfile
from collections.abc import Iterator
from types import SimpleNamespace

import node_rl_ladder
import node_rl_runs as runs

# rows nothing else reads (node.py --skip): each a full rvn-rl run of a minute or two on the node; rl_envs: all the
# envs-alone rows (measured together on the fifth GPU run, docs/results/2026-12-04_gpu5); rl_layouts: the envs
# alone in each layout of node_rl_ladder.layouts
SKIPPABLE = ("rl_overlap", "rl_envs", "rl_paper", "rl_compiled", "rl_scene_steps", "rl_layouts")


def rl_rows(plan) -> Iterator[dict]:
    """5. rvn-rl PPO collection + learning with envs in worker processes: env steps/s at scale=small (ResNet-18, 128², 4
    PPO epochs x 4 mini-batches of 64-step rollouts) and at the paper's network and PPO settings (half-width ResNet-50,
    256² pooled to 128, 2 epochs x 2 mini-batches of 128-step rollouts; beside DD-PPO's ~160 frames/s per GPU), both
    with the same envs on ``plan.rl_scenes`` train scenes (200: envs keep loading scenes they have not seen, as a run
    over all 800 does). A first run of two updates (the first one loads scenes: not counted) times an update; when that
    left part of ``plan.seconds``, the run resumes for as many more updates as fit (the first again not counted; on a
    normal run every update that began in the run's first ``plan.rl_warm_seconds``, its envs' scene-prefetch helpers
    starting, and the first run only times an update). Overlapped rows run one update more and leave each run's last out
    too (nothing is collected beside it: `rl.steady_updates`). ``rl_bf16``: the rl row with train.precision=bf16 (the
    visual encoder under torch.autocast(bfloat16) in rollouts and updates), naming its ratio to the rl row (--quick on a
    CPU that emulates bfloat16 skips it: the row took 36-46 s of a 2-minute quick run on the 2-core development
    machine); ``rl_overlap``: with train.overlap=true (each PPO update in a learner thread while the envs collect the
    next rollout) and, as the recipe pairs them, ppo.recompute_advantages=true (the values recomputed with the learner's
    weights, one forward pass an update: overlap alone collided more, docs/results/2026-12-02_rl_overlap), naming its
    ratio too; with CUDA, after the envs-alone rows and ``rl_paper``, ``rl_compiled``: with train.compile=true (the
    visual trunk's forward and backward as CUDA graphs; its compiling falls in the first, uncounted update), naming its
    ratio too. With CUDA (and --quick), the envs alone (``rl_envs``): with env.prefetch_scenes (the default), without it
    (``rl_envs_no_prefetch``: vectorised envs then wait for whichever env switches scene, the bound of the third GPU
    run, docs/results/2026-11-27_gpu3) and in one worker (``rl_envs_1``), each after ``plan.rl_warm_seconds`` of
    warm-up. With CUDA, after rl_bf16, the env workers' layout and a ladder of levers on the faster one
    (node_rl_ladder.py). The second and third GPU runs also timed renderer=raycast and gl under __GL_YIELD=USLEEP:
    neither helped (the GL calls of many processes may bound the envs: node_rl_ladder's layouts ask). Last, the envs
    alone with fresh goals (``rl_envs_fresh_goals``, env.goal_pool=0) against the pool's 64 solves a scene.

    Every row but one runs over one cache root that holds the scenes' built navmeshes and goal pools
    (`node_rl_runs.fill_scene_caches`, before the rows): what a long run sees after its first pass over its scenes,
    since both are kept on disk (`rvn_data.navmesh.disk_cache`, `rvn_data.benchmark.pool_cache`). ``rl_envs_first_pass``
    times the envs alone over an empty root (each scene's navmesh built and pool solved and smoothed at its first visit,
    as every row of the first three GPU runs did, the smoothing since 2026-12-02)."""
    small = dict(size=plan.rl_size, backbone="resnet18", num_steps=plan.rl_num_steps, ppo_epoch=4,
                 mini_batches=min(4, plan.rl_envs))
    paper = dict(size=plan.rl_paper_size, backbone="resnet50", num_steps=2 * plan.rl_num_steps, ppo_epoch=2,
                 mini_batches=min(2, plan.rl_envs))
    from rvn_rl.trainer import native_bf16_cpu

    what = "scale=paper network and PPO"
    ddppo = "DD-PPO (Wijmans et al. 2020): ~160 frames/s per GPU (2.5B frames, 180 GPU-days)"
    with tempfile.TemporaryDirectory() as kept:
        plan = SimpleNamespace(**vars(plan), rl_cache=kept, rl_filled=runs.fill_scene_caches(plan, small, kept))
        plain = runs.rl_row(plan, "rl", "scale=small", small, "rl", "")
        yield plain
        yield runs.rl_row(plan, "rl_scene_steps", f"scale=small, {runs.HABITAT_LABEL}",
                          {**small, **runs.HABITAT_SWITCH}, "rl", "", against=plain["value"])
        bf16 = "scale=small, train.precision=bf16"
        if plan.quick and not plan.cuda and not native_bf16_cpu():  # a smoke test: the emulation's minute spared
            yield runs.skipped_rl_row("rl_bf16", bf16, "bfloat16 is emulated on this CPU (no AVX512-BF16 or AMX; "
                                      "rvn_rl/README.md), --quick leaves it out; a run without --quick times it")
        elif plan.cuda:  # the lease's minute for the rows below
            yield runs.skipped_rl_row("rl_bf16", bf16, "measured on an H200 on 2026-12-04: x0.74 the rl row "
                                      "(host-bound; autocast adds launches), docs/results/2026-12-04_gpu4")
        else:
            yield runs.rl_row(plan, "rl_bf16", bf16, {**small, "precision": "bf16"}, "rl", "", against=plain["value"])
        if plan.cuda:  # the workers' layout, then a ladder of levers on the faster one (node_rl_ladder)
            base = yield from node_rl_ladder.layout_rows(plan, small, plain)
            yield from node_rl_ladder.graph_act_rows(plan, base, plain["value"])
        else:
            yield runs.skipped_rl_row("rl_graph_act", "scale=small, train.graph_act=true",
                                      "CUDA graphs need a GPU (on a CPU train.graph_act acts as without it)")
        yield runs.rl_row(plan, "rl_overlap", "scale=small, train.overlap=true, ppo.recompute_advantages=true",
                          {**small, "overlap": True, "recompute": True}, "rl", "", against=plain["value"])
        if (plan.cuda or plan.quick) and "rl_envs" not in plan.skip:
            envs = runs.rl_envs_row(plan, small)
            yield envs
            if plan.cuda:  # do GL's calls from many processes bound the envs? none, then more views a call
                yield runs.rl_envs_row(plan, small, renderer="raycast", against=envs["value"])
                yield runs.rl_envs_row(plan, small, workers=plan.rl_workers, per_worker=4, against=envs["value"])
                yield runs.rl_envs_row(plan, small, workers=4, per_worker=8, against=envs["value"])
            yield runs.rl_envs_row(plan, small, first_pass=True, kept_caches=envs["value"])
            yield runs.rl_envs_row(plan, small, prefetch=False, with_prefetch=envs["value"])
            if plan.rl_workers > 1 or plan.quick:  # a per-worker rate that drops with more workers: contention
                yield runs.rl_envs_row(plan, small, workers=1)
        if plan.cuda or plan.quick:  # before rl_compiled: the fourth GPU run's time limit cut it there
            yield runs.rl_row(plan, "rl_paper", what, paper, None, ddppo)
        else:  # minutes per update on a few cores; --quick runs it small
            yield runs.skipped_rl_row("rl_paper", what,
                                      "ResNet-50 at 256² is sized for a GPU (--quick runs it at 64²)")
        if plan.cuda:  # the trunk's forward and backward as CUDA graphs (train.compile, reduce-overhead)
            yield runs.rl_row(plan, "rl_compiled", "scale=small, train.compile=true (reduce-overhead)",
                              {**small, "compile": True}, "rl", "", against=plain["value"])
        else:
            yield runs.skipped_rl_row("rl_compiled", "scale=small, train.compile=true", "CUDA graphs need a GPU (on "
                                      "a CPU the compiled trunk was not faster: rvn_rl/settings.py)")
        if not (plan.cuda or plan.quick) or "rl_envs" in plan.skip:
            return
        # last: what a lease that runs short loses
        yield runs.rl_envs_row(plan, small, goal_pool=0, with_pool=envs["value"])
