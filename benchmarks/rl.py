"""RL figures (issue 16): env steps/s of rvn-rl's collection alone and of collection + learning,
at 128x128 RGB with the ResNet-18 policy (goals on a 2-core CPU: >= 800 and >= 200).

1. env: the batched envs stepped with random actions (no network), with the goal pool and
   with fresh goals per draw (``env.goal_pool=0``, the ratio against it printed); the same on
   ``--many-scenes`` scenes (default 200), where most scene switches load a scene this process has not
   seen (a run over all 800 train scenes), both ways, and with fresh goals again once the cache root keeps
   every visited scene's built navmesh (`rvn_data.navmesh.disk_cache`); and in this
   process, their frames rendered together (`rvn_data.render.render_views`: gl draws them in one
   pass with one GPU synchronisation) against each env rendering its own (best of two, alternated);
2. collection: envs + the policy's act() (what a rollout costs);
3. collection + learning: rvn-rl's own loop (``train()``) for a few PPO updates, its fps;
4. the compute ceiling of 2 and 3: the policy's forward FLOPs per frame (torch's FlopCounterMode)
   against this CPU's float32 matmul rate at ``--threads`` (a bound convolutions do not reach):
   collection costs one forward per env step, PPO one more forward + backward (~3 forwards) per
   epoch.
Train-mode envs on ``--scenes`` procedural train scenes, their loading excluded (warm-up).
Run: python benchmarks/rl.py [--envs 8] [--workers 0] [--steps 400] [--updates 3] [--ppo-epoch 2 --mini-batches 2]
"""
from __future__ import annotations

import argparse
import json
import tempfile
import time

import numpy as np
import torch


def overrides(args, out_dir: str) -> list[str]:
    return [f"env.size={args.size}", f"env.num_envs={args.envs}", f"env.workers={args.workers}",
            f"env.num_scenes={args.scenes}", f"model.backbone={getattr(args, 'backbone', 'resnet18')}", f"model.base_planes={args.base_planes}",
            f"model.ngroups={min(16, args.base_planes // 2)}", f"ppo.num_steps={args.num_steps}",
            f"train.threads={args.threads}", "progress=false", f"renderer={args.renderer}", f"out_dir={out_dir}",
            f"train.total_steps={args.updates * args.num_steps * args.envs}", "train.checkpoint_every=1000",
            f"env.goal_pool={args.goal_pool}", f"ppo.ppo_epoch={args.ppo_epoch}",
            f"ppo.num_mini_batch={args.mini_batches}",
            f"train.precision={getattr(args, 'precision', 'fp32')}",
            f"train.compile={str(getattr(args, 'compile', False)).lower()}",
            f"train.overlap={str(getattr(args, 'overlap', False)).lower()}",
            f"ppo.recompute_advantages={str(getattr(args, 'recompute', False)).lower()}",
            f"train.graph_act={str(getattr(args, 'graph_act', False)).lower()}",
            f"train.double_buffered={str(getattr(args, 'double_buffered', False)).lower()}",
            # else out_dir/cache, given: rvn-rl would take $RVN_CACHE_DIR first (the recipes export it), and runs
            # timed over an empty cache root would read a filled one
            f"cache_dir={getattr(args, 'cache_dir', None) or out_dir + '/cache'}"] + [
                f"env.{k}={getattr(args, k)}" for k in ("scene_switch_every", "scene_switch_steps")
                if getattr(args, k, None) is not None]  # else rvn-rl's default scene switches


def update_seconds(update: dict, envs: int) -> float:
    """The seconds of one update of rvn-rl's metrics.jsonl (``envs`` envs): its env steps over its env steps/s."""
    return update["rollout_steps"] * envs / update["fps"]


def steady_updates(rows: list[dict], warm_seconds: float = 0.0, envs: int = 1) -> list[dict]:
    """The updates of an rvn-rl run's metrics.jsonl rows that show its steady state: not the first (it loads scenes
    and warms up), nor those that began within ``warm_seconds`` of the run's start (each of the ``envs`` envs'
    scene-prefetch helper process starts at the env's first scene and takes ~1.3 s to its first prepared scene on the
    development CPU, 0.1-0.2 s a scene after that: 30 envs' helpers load a node's cores for their first seconds), and
    with train.overlap not the last, whose time holds no collection beside the update (the rollout it is credited with
    was collected during the update before it)."""
    began, skip = 0.0, 1
    for i, r in enumerate(rows):
        if i >= 1 and began >= warm_seconds:
            break
        began += update_seconds(r, envs)
        skip = i + 1
    rows = rows[skip:]
    overlapped = any(r.get("overlapped") for r in rows)
    return [r for r in rows if r.get("overlapped")] if overlapped else rows


def collection(cfg, steps: int, with_policy: bool, times: list | None = None, seconds: float = 0.0,
               warm_seconds: float = 0.0) -> float:
    """Env steps/s of ``steps`` batched steps after 10 of warm-up and more until ``warm_seconds`` have passed (the
    envs' scene-prefetch helpers started: `steady_updates`), and more until ``seconds`` have passed (so that a
    fast machine's figure holds as many scene switches as a slow one's): random actions, or ``with_policy`` the
    policy's act(); ``times`` (a list) receives each timed batched step's seconds."""
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.trainer import set_trunk
    from rvn_rl.vec_procs import make_envs

    envs = make_envs(cfg.env_kwargs(), cfg.env, seed=0)
    n = envs.num_envs
    rng = np.random.default_rng(0)
    net = PointNavResNetPolicy(**cfg.model_kwargs()).eval() if with_policy else None
    if net is not None:
        set_trunk(net, cfg.train)
    state, prev, masks = (net.initial_state(n), torch.zeros(n, dtype=torch.long), torch.zeros(n)) if net else (0, 0, 0)
    try:
        obs = envs.reset()

        def run(k, times=None):
            nonlocal obs, state, prev, masks
            for _ in range(k):
                t_step = time.perf_counter()
                if net is None:
                    actions = rng.integers(0, 4, n)
                else:
                    with torch.no_grad():
                        t = {key: torch.as_tensor(v) for key, v in obs.items()}
                        a, _, _, state = net.act(t, state, prev, masks)
                    actions, prev = a.numpy(), a
                obs, _, _, done, _ = envs.step(actions)
                if net is not None:
                    masks = torch.as_tensor(~done, dtype=torch.float32)
                if times is not None:
                    times.append(time.perf_counter() - t_step)

        t = time.perf_counter()
        run(10)  # warm-up: scenes of the first resets loaded, numba compiled
        while time.perf_counter() - t < warm_seconds:
            run(8)
        t = time.perf_counter()
        run(steps, times)
        done = steps
        while time.perf_counter() - t < seconds:
            run(8, times)
            done += 8
        return done * n / (time.perf_counter() - t)
    finally:
        envs.close()


def learner_profile(cfg, device: str = "cpu", rows: int = 30) -> str:
    """torch.profiler's operator table (`op_profile.op_table`) of rvn-rl's learner side of one update, without the
    envs: ``ppo.num_steps`` batched ``act()`` calls on ``env.num_envs`` observations with their storage, then the
    returns and the PPO update, as `rvn_rl.trainer` runs them on ``device``, on random frames and rewards. Its phases
    (act, storage, returns, update) say where an rl row's "policy and storage" and "PPO update" shares go once the
    envs are fast (on the third GPU run: 7 % and 15 % of an update, ~0.5 and ~1.1 s, a bound of ~1,200 env steps/s
    for 30 envs even with envs that took no time)."""
    from op_profile import op_table, phase
    from rvn_il.train.choices import fused_on
    from rvn_rl.model import PointNavResNetPolicy
    from rvn_rl.ppo import ppo_update
    from rvn_rl.rollout import DeviceRollouts, RolloutStorage, to_device
    from rvn_rl.trainer import _Evaluate, set_trunk

    dev, ppo, n, size = torch.device(device), cfg.ppo, cfg.env.num_envs, cfg.env.size
    torch.manual_seed(0)
    policy = PointNavResNetPolicy(**cfg.model_kwargs()).to(dev)
    set_trunk(policy, cfg.train)  # a compiled trunk compiles in the warm-up update
    learner = _Evaluate(policy)
    optimizer = torch.optim.Adam(policy.parameters(), lr=ppo.lr, eps=ppo.eps, fused=fused_on(dev))  # as rvn-rl's
    rng = np.random.default_rng(0)

    def observation() -> dict:
        return {"rgb": rng.integers(0, 256, (n, size, size, 3), dtype=np.uint8),
                "pointgoal": rng.normal(size=(n, 2)).astype(np.float32)}

    space = {"rgb": ((size, size, 3), torch.uint8), "pointgoal": ((2,), torch.float32)}
    state = policy.initial_state(n, dev)
    rollouts = RolloutStorage(ppo.num_steps, n, space, tuple(state.shape), 1)
    frames = [observation() for _ in range(4)]
    gen = torch.Generator().manual_seed(0)

    def update() -> None:
        nonlocal state
        rollouts.set_first(frames[0], state.cpu(), torch.zeros(n, dtype=torch.long), torch.zeros(n))
        policy.eval()
        for t in range(ppo.num_steps):
            with phase("act"):
                o, prev, masks = rollouts.current()
                with torch.no_grad():
                    action, logp, values, state = policy.act(to_device(o, dev), state, prev.to(dev), masks.to(dev))
                actions = action.cpu()
            with phase("storage"):
                rollouts.insert(frames[(t + 1) % len(frames)], actions, logp.cpu(), values.cpu(),
                                rng.normal(size=(n, 1)).astype(np.float32), rng.random(n) < 0.05)
        with phase("returns"):
            o, prev, masks = rollouts.current()
            with torch.no_grad():
                feats, _ = policy(to_device(o, dev), state, prev.to(dev), masks.to(dev))
                rollouts.compute_returns(policy.values(feats).cpu(), ppo.gamma, ppo.tau)
        policy.train()
        with phase("update"):
            ppo_update(learner, optimizer, DeviceRollouts(rollouts, dev), ppo, gen)
        state = state.detach()

    update()  # warm-up: cuDNN's choices, the allocator
    return op_table(update, dev.type == "cuda", rows=rows)


def forward_gflop(cfg, n: int = 8) -> float:
    """GFLOP of one batched ``act()`` of the policy, per frame."""
    from torch.utils.flop_counter import FlopCounterMode

    from rvn_rl.model import PointNavResNetPolicy

    net = PointNavResNetPolicy(**cfg.model_kwargs()).eval()
    size = cfg.env.size
    obs = {"rgb": torch.zeros(n, size, size, 3, dtype=torch.uint8), "pointgoal": torch.ones(n, 2)}  # algo=ppo: RGB only
    counter = FlopCounterMode(display=False)
    with counter, torch.no_grad():
        net.act(obs, net.initial_state(n), torch.zeros(n, dtype=torch.long), torch.zeros(n))
    return counter.get_total_flops() / n / 1e9


def matmul_gflops(size: int = 1024, reps: int = 30) -> float:
    """float32 matmul GFLOP/s at torch's current thread count (the best of 3 timings)."""
    a, b = torch.randn(size, size), torch.randn(size, size)
    for _ in range(3):
        a @ b
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        for _ in range(reps):
            a @ b
        best = min(best, time.perf_counter() - t)
    return reps * 2 * size**3 / best / 1e9


def frames_rate(cfg, steps: int, together: bool) -> float:
    """Env steps/s of ``env.num_envs`` envs in this process with random actions: `BatchEnv.step`
    (the envs' frames rendered together, `render_views`) or, ``together=False``, each env's own
    `step` (one render and, with gl, one GPU synchronisation per env per step)."""
    from rvn_rl.vec_env import BatchEnv

    envs = BatchEnv(cfg.env_kwargs(), cfg.env.num_envs, seed=0, scene_cache=cfg.env.scene_cache)
    n, rng = envs.num_envs, np.random.default_rng(0)
    try:
        envs.reset()

        def run(k):
            for _ in range(k):
                actions = rng.integers(0, 4, n)
                if together:
                    envs.step(actions)
                    continue
                for env, a in zip(envs.envs, actions):
                    if env.step(int(a))[2:4] != (False, False):
                        env.reset()

        run(10)  # warm-up: scenes of the first resets loaded
        t = time.perf_counter()
        run(steps)
        return steps * n / (time.perf_counter() - t)
    finally:
        envs.close()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--envs", type=int, default=8)
    p.add_argument("--workers", type=int, default=0, help="env worker processes (0: in process)")
    p.add_argument("--scenes", type=int, default=4)
    p.add_argument("--steps", type=int, default=100, help="batched steps per collection measurement")
    p.add_argument("--updates", type=int, default=3)
    p.add_argument("--num-steps", type=int, default=32, help="rollout length of the learning measurement")
    p.add_argument("--ppo-epoch", type=int, default=2, help="PPO epochs per rollout (2: the paper's; scale=small uses 4)")
    p.add_argument("--mini-batches", type=int, default=2, help="mini-batches per epoch (2: the paper's; scale=small 4)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--base-planes", type=int, default=32, help="ResNet base width (32: DD-PPO's half width)")
    p.add_argument("--renderer", default="auto")
    p.add_argument("--goal-pool", type=int, default=64, help="env.goal_pool (0: fresh goals, two Dijkstra solves each)")
    p.add_argument("--many-scenes", type=int, default=200, help="scenes of the cold-switch figure (0: none)")
    p.add_argument("--many-steps", type=int, default=300, help="batched steps of the cold-switch figure")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    from rvn_rl.cli import compose
    from rvn_rl.trainer import train

    with tempfile.TemporaryDirectory() as tmp:
        cfg = compose(overrides(args, f"{tmp}/run"))
        env_sps = collection(cfg, args.steps, with_policy=False)
        together = [frames_rate(cfg, args.steps // 2, k % 2 == 0) for k in range(4)]  # alternated, in this process
        fresh_sps = collection(compose(overrides(args, f"{tmp}/run") + ["env.goal_pool=0"]), args.steps, False)
        # each cold run with a cache root of its own; the last reads the navmeshes the fresh-goals run kept
        many = [collection(compose(overrides(args, f"{tmp}/{name}") + [f"env.num_scenes={args.many_scenes}", f"env.goal_pool={g}"]),
                           args.many_steps, False)
                for name, g in (("pool", args.goal_pool), ("fresh", 0), ("fresh", 0))] if args.many_scenes else None
        col_sps = collection(cfg, args.steps, with_policy=True)
        train(cfg)
        rows = [json.loads(line) for line in open(f"{tmp}/run/metrics.jsonl")]
        gflop, peak = forward_gflop(cfg), matmul_gflops()
        epochs, mini_batches = cfg.ppo.ppo_epoch, cfg.ppo.num_mini_batch
    learn = steady_updates(rows) or rows  # the first update includes scene loading
    fps = sum(r["rollout_steps"] * args.envs for r in learn) / sum(update_seconds(r, args.envs) for r in learn)
    print(f"rvn-rl at {args.size}x{args.size} RGB, resnet18 (base planes {args.base_planes}), {args.envs} envs, workers={args.workers}, "
          f"{args.threads} torch threads:")
    print(f"  env steps/s, envs alone (random actions): {env_sps:8.0f}   (goal_pool={args.goal_pool}; "
          f"{fresh_sps:.0f} with fresh goals, x{env_sps / fresh_sps:.2f})")
    if many:
        print(f"  env steps/s on {args.many_scenes} scenes (cold scene switches): {many[0]:8.0f}   (goal_pool={args.goal_pool}; "
              f"{many[1]:.0f} with fresh goals, x{many[0] / many[1]:.2f})")
        print(f"  the same, fresh goals, navmeshes kept   : {many[2]:8.0f}   (read from the cache root a first run filled, "
              f"as a long run does after its first visit to each scene: x{many[2] / many[1]:.2f})")
    both, alone = max(together[0::2]), max(together[1::2])
    print(f"  env steps/s, {args.envs} envs in this process      : {both:8.0f}   (frames rendered together; each env "
          f"rendering its own frame: {alone:.0f}, x{both / alone:.2f})")
    print(f"  env steps/s, collection (envs + policy) : {col_sps:8.0f}   (goal >= 800)")
    print(f"  env steps/s, collection + learning      : {fps:8.0f}   (goal >= 200; PPO {learn[0]['rollout_steps']:.0f}-step "
          f"rollouts, {epochs} epochs x {mini_batches} mini-batches)")
    print(f"  compute ceiling: the policy's forward is {gflop:.3f} GFLOP per frame; float32 matmul runs at {peak:.0f} GFLOP/s "
          f"here, so at most {peak / gflop:.0f} env steps/s of collection and {peak / (gflop * (1 + 3 * epochs)):.0f} of "
          f"collection + learning with the envs free")


if __name__ == "__main__":
    main()
