"""The rvn-rl training loop. `train` checks the settings, device and out_dir (nothing is written before), then builds
the `Run` (policy, its learner replica, optimiser, Lagrange multiplier, counters, resumed from out_dir's latest
checkpoint when there is one, else from ``train.continue_from``'s), the environments and the log, and runs `_loop`:
collect a rollout of ``ppo.num_steps`` steps (`rvn_rl.collect`; DD-PPO ranks may stop early once ``ddppo.sync_frac``
of the ranks finished), GAE, the Lagrange multiplier for PPO-Lagrangian, a PPO update through a
DistributedDataParallel replica when distributed, the log row and resumable checkpoints in ``out_dir``. Each setting
group goes to where it acts: ``ppo`` to the rollout and the update, ``env`` to the environments, ``algo`` to the
multiplier, ``train`` to the loop's length, checkpoints, the visual trunk's precision and compilation,
``train.overlap`` (each update in a learner thread while a copy of the policy collects the next rollout:
`rvn_rl.overlap`), ``train.graph_act`` (`rvn_rl.graphed`) and ``train.double_buffered`` (`rvn_rl.collect`)."""
from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from rvn_data.cache_root import ENV as CACHE_ENV, keep_compiled_kernels
from rvn_data.cli.common import check_writable_dir, validating
from rvn_data.numba_note import note_first_compile
from rvn_il.train.choices import check_precision_on, fused_on, load_optimizer_state

from . import checkpoint as ck
from .collect import action_generator, collect
from .config import RLConfig
from .distrib import Dist, init, pick_device, shutdown
from .graphed import GraphedAct
from .model import PointNavResNetPolicy
from .overlap import LearnerThread, make_actor
from .ppo import Lagrange, ppo_update
from .rollout import DeviceRollouts, RolloutStorage
from .runlog import RunLog, episode_sums, plot_learning_curve, summary
from .settings import AlgoConfig, PPOConfig, TrainSettings
from .vec_env import quiet_scene_logs
from .vec_procs import make_envs


logger = logging.getLogger(__name__)


def native_bf16_cpu() -> bool:
    """Whether this CPU computes bfloat16 natively: on x86, AVX512-BF16 or AMX tiles (without them oneDNN emulates
    it); True where torch cannot tell (other architectures, a torch without the probes)."""
    import platform

    if platform.machine().lower() not in ("x86_64", "amd64", "i386", "i686"):
        return True
    probes = [getattr(torch.cpu, name, None) for name in ("_is_avx512_bf16_supported", "_is_amx_tile_supported")]
    probes = [probe for probe in probes if probe is not None]
    return not probes or any(probe() for probe in probes)


def set_trunk(policy: PointNavResNetPolicy, train: TrainSettings) -> None:
    """``train.precision`` and ``train.compile`` on ``policy``'s visual trunk, as rvn-rl's rollouts and updates run
    it (the compiled kernels go where the process put inductor's cache)."""
    policy.autocast_bf16 = train.precision == "bf16"
    if train.compile:
        policy.compile_visual(train.compile_mode)


class _Evaluate(nn.Module):
    """Forward = the policy's ``evaluate`` (what DistributedDataParallel wraps)."""

    def __init__(self, policy: PointNavResNetPolicy):
        super().__init__()
        self.policy = policy

    def forward(self, obs, state, prev_actions, masks, actions, pieces=None):
        return self.policy.evaluate(obs, state, prev_actions, masks, actions, pieces)


def _replica(learner: nn.Module, device: torch.device) -> nn.Module:
    """The DistributedDataParallel replica of ``learner``. Its buffers (the visual input's running mean and variance,
    which the module averages over ranks itself) are not synced at each forward: ``forward_sync_buffers=False`` where
    torch has it (2.13 deprecates ``broadcast_buffers``). Unlike ``broadcast_buffers=False`` it syncs them once at the
    start, which copies rank 0's buffers over every rank's equal ones (one seed, or one checkpoint): a 2-rank run gives
    the same weights to the byte either way. The gradients of the stride-2 1x1 downsample convolutions come
    out of backward with channels-last strides on a CPU, which over a kernel of 1x1 are the same bytes as the weights'
    own; DDP then copies them into its bucket instead of using them in place (three tensors of at most 8,192 elements
    at base_planes 16) and says so once a rank, "Grad strides do not match bucket view strides": not a fault here, so
    not said (tests/test_rl_ddppo.py)."""
    import inspect
    import warnings

    from torch.nn.parallel import DistributedDataParallel as DDP

    sync = "forward_sync_buffers" if "forward_sync_buffers" in inspect.signature(DDP).parameters else "broadcast_buffers"
    warnings.filterwarnings("ignore", message="Grad strides do not match bucket view strides", category=UserWarning)
    return DDP(learner, device_ids=[device.index] if device.type == "cuda" else None, find_unused_parameters=False,
               gradient_as_bucket_view=True, **{sync: False})


@dataclass
class Run:
    """What the loop carries from one update to the next, and what a checkpoint restores."""

    policy: PointNavResNetPolicy
    learner: nn.Module  # the policy's ``evaluate``: a DistributedDataParallel replica when distributed
    optimizer: torch.optim.Optimizer
    lagrange: Lagrange | None  # PPO-Lagrangian's multiplier
    gen: torch.Generator  # the order of the mini-batches
    env_steps: int = 0  # over all ranks
    updates: int = 0
    ep_cost: float = 0.0  # the last mean episode cost J_c (PPO-Lagrangian)

    @classmethod
    def start(cls, seed: int, policy_kwargs: dict, ppo: PPOConfig, algo: AlgoConfig, d: Dist, device,
              resume_from: Path | None) -> "Run":
        """The network (the same initial weights on every rank), its optimiser and (algo.lagrangian) multiplier,
        continued from ``resume_from``'s weights and state.pt when given: its moments and counters, stepping by this
        run's settings (ppo.lr, ppo.eps, algo.lambda_lr: those config.yaml records)."""
        torch.manual_seed(seed)  # the initial weights, the same on every rank (actions: `collect.action_generator`)
        policy = PointNavResNetPolicy(**policy_kwargs).to(device)
        state = ck.load(resume_from, policy) if resume_from is not None else {}
        optimizer = torch.optim.Adam(policy.parameters(), lr=ppo.lr, eps=ppo.eps, fused=fused_on(device))
        if state:
            load_optimizer_state(optimizer, state["optimizer"], device)
            for group in optimizer.param_groups:  # this run's ppo.lr and ppo.eps (config.yaml's), not the checkpoint's
                group.update(lr=ppo.lr, eps=ppo.eps)
        lagrange = None
        if algo.lagrangian:
            lagrange = Lagrange(algo.cost_limit, algo.lambda_init, algo.lambda_lr, algo.lambda_max)
            if state:
                lagrange.load_state_dict(state["lagrange"])
        learner = _Evaluate(policy)
        if d.enabled:
            learner = _replica(learner, device)
        updates = state.get("updates", 0)
        gen = torch.Generator().manual_seed(int(np.random.SeedSequence([seed, d.rank, updates]).generate_state(1)[0]))
        return cls(policy, learner, optimizer, lagrange, gen, state.get("env_steps", 0), updates,
                   state.get("ep_cost", 0.0))

    def resume_state(self) -> dict:
        """A checkpoint's state.pt: what a resumed run needs besides the weights."""
        state = {"optimizer": self.optimizer.state_dict(), "env_steps": self.env_steps, "updates": self.updates,
                 "ep_cost": self.ep_cost}
        if self.lagrange is not None:
            state["lagrange"] = self.lagrange.state_dict()
        return state


def train(cfg: RLConfig, on_checked=None) -> dict:
    """Train; settings, device and out_dir are checked first (`ConfigError`, nothing written),
    then ``on_checked()`` runs. A run whose latest checkpoint has train.total_steps already returns at once, writing
    nothing: {"env_steps", "finished": the line that says so (rank 0)}."""
    d = init(cfg.ddppo.backend, cfg.device)
    try:
        with validating():
            device = pick_device(cfg.device, d)
            cfg.validate(d.world_size)
            check_precision_on(cfg.train.precision, device)  # rvn-train's: a GPU without bfloat16
            if cfg.train.graph_act and device.type != "cuda":
                logger.warning("train.graph_act=true records the act as a CUDA graph, and this run's device is %s: "
                               "its acts run as without it (the same actions); use device=cuda on a GPU",
                               device.type)
            if cfg.train.double_buffered and device.type == "cpu":
                logger.warning("train.double_buffered=true on a CPU: the acts' convolutions share the cores with the "
                               "env workers and cost about as much for half the envs as for all (collection x0.83 on "
                               "the 2-core development CPU, rvn_rl/README.md); it is meant for a GPU with "
                               "train.graph_act=true")
            if cfg.train.precision == "bf16" and device.type == "cpu" and not native_bf16_cpu():
                logger.warning("train.precision=bf16 on a CPU without native bfloat16 (AVX512-BF16 or AMX): its "
                               "convolutions are emulated, 16x slower than float32 in a measurement "
                               "(rvn_rl/README.md); use train.precision=fp32")
            # what the run takes from its settings: the network's and the environments' arguments, config.yaml's record
            policy_kwargs, env_kwargs, record = cfg.model_kwargs(), cfg.env_kwargs(), cfg.record()
            out_dir = check_writable_dir(Path(cfg.out_dir).expanduser())
            if cfg.cache_dir or os.environ.get(CACHE_ENV):  # else <out_dir>/cache, checked with out_dir
                check_writable_dir(env_kwargs["cache_dir"], "cache_dir=" if cfg.cache_dir else f"{CACHE_ENV}=")
            resume_from = ck.resume_point(out_dir, policy_kwargs, cfg.algo.name, cfg.train.resume, record["depth"])
            own, origin = resume_from, None
            if cfg.train.continue_from:  # another run's checkpoint, continued in this out_dir
                resume_from, origin = ck.continue_point(Path(cfg.train.continue_from), out_dir, policy_kwargs,
                                                        cfg.algo.name, record["depth"], own)
            done = ck.env_steps_of(resume_from) if resume_from is not None else 0
            if origin is not None and own is None and done >= cfg.train.total_steps:
                raise ValueError(f"train.continue_from={origin['out_dir']} stopped at {done} env steps, "
                                 f"train.total_steps={cfg.train.total_steps}: nothing to train; raise "
                                 f"train.total_steps above {done}")
        if done >= cfg.train.total_steps:  # a finished run: nothing to collect, nothing written
            said = (f"rvn-rl {cfg.algo.name}: out_dir={out_dir} holds a finished run ({done} env steps, "
                    f"train.total_steps={cfg.train.total_steps}); nothing to train: raise train.total_steps to go on")
            return {"env_steps": done, **({"finished": said} if d.rank == 0 else {})}
        if on_checked is not None:
            on_checked()
        if d.rank == 0:
            ck.write_config(out_dir, {**record, "policy": policy_kwargs}, resuming=own is not None,
                            continued_from=origin)
            if origin is not None and own is None:
                ck.continue_log(Path(origin["out_dir"]), out_dir, done)
        if cfg.train.threads:
            torch.set_num_threads(cfg.train.threads)
        run = Run.start(cfg.seed, policy_kwargs, cfg.ppo, cfg.algo, d, device, resume_from)
        actor = make_actor(run.policy, cfg.train) if cfg.train.overlap else None  # a copy, before set_trunk compiles
        if cfg.train.compile:  # kernels under the cache root, beside the navmeshes and goal pools
            keep_compiled_kernels(env_kwargs["cache_dir"])
        set_trunk(run.policy, cfg.train)  # rollouts and updates alike
        if d.rank == 0:
            note_first_compile("rvn-rl")
        depth_fn = None
        if cfg.uses_predicted_depth:  # the frozen depth network, on the policy's device
            from .depth import load_depth_model
            depth_fn = load_depth_model(str(cfg.depth.model_path), device=device)
        envs = make_envs(env_kwargs, cfg.env, seed=cfg.seed + 7919 * run.updates, rank=d.rank, depth_fn=depth_fn)
        log = RunLog(out_dir, d.rank == 0, env_steps=run.env_steps)  # an earlier run's rows past them dropped
        try:
            result = _loop(run, envs, log, cfg, d, device, out_dir, actor)
        finally:
            envs.close()
            log.close()
        if d.rank == 0:
            plot_learning_curve(out_dir, f"rvn-rl {cfg.algo.name}")
        return result
    finally:
        shutdown()


def _loop(run: Run, envs, log: RunLog, cfg: RLConfig, d: Dist, device, out_dir: Path, actor=None) -> dict:
    """Rollouts and updates until ``train.total_steps`` env steps; rank 0 checkpoints every
    ``train.checkpoint_every`` updates and at the end, and closes with the run's summary. With ``actor``
    (train.overlap: `overlap.make_actor`), each update runs in the learner thread while ``actor`` collects the next
    rollout into the other of two buffers; the actor then takes the updated weights."""
    from tqdm import tqdm

    ppo, total = cfg.ppo, cfg.train.total_steps
    policy, n, heads = run.policy, envs.num_envs, 2 if run.lagrange is not None else 1
    obs = envs.reset()
    quiet_scene_logs()  # the first scenes' renderer lines are enough (env workers do the same)
    space = {k: (v.shape[1:], torch.uint8 if v.dtype == np.uint8 else torch.float32) for k, v in obs.items()}
    state = policy.initial_state(n, device)
    buffers = [RolloutStorage(ppo.num_steps, n, space, tuple(state.shape), heads) for _ in range(1 + (actor is not None))]
    buffers[0].set_first(obs, state.cpu(), torch.zeros(n, dtype=torch.long), torch.zeros(n))
    batches = [DeviceRollouts(b, device) for b in buffers]  # the update's mini-batches, on the learner's device
    learner = LearnerThread(actor is not None, device)
    acts = action_generator(cfg.seed, d.rank, run.updates, device)  # each rank's own, continued runs' own
    actor = policy if actor is None else actor
    if cfg.train.graph_act:  # recorded at the first act, before the learner thread starts
        actor = GraphedAct(actor, cuda_graph=device.type == "cuda")
    bar = tqdm(total=total, initial=min(run.env_steps, total), unit="step", desc=f"rvn-rl {cfg.algo.name}",
               disable=d.rank != 0 or not cfg.progress, smoothing=0.1)
    t_start, steps_start = time.perf_counter(), run.env_steps
    t0, cur = t_start, 0
    state, episodes, t_env, delta = collect(actor, envs, buffers[cur], state, run, cfg, d, device, heads, acts)
    t_collect = time.perf_counter() - t0
    try:
        while True:
            sums = episode_sums(episodes)
            # lambda steps on the J_c of this rollout's episodes; none ended: no measure, no step (Adam's step is ~lr
            # whatever the gradient, so stepping on a J_c of 0 or on the last one again is not neutral)
            if run.lagrange is not None and sums[0] > 0:
                run.ep_cost = float(sums[6] / sums[0])
                run.lagrange.update(run.ep_cost)
            policy.train()
            more = run.env_steps + delta < total  # another rollout after this update
            overlapped = more and len(buffers) == 2  # train.overlap: that rollout collected while this update runs
            t_learn = time.perf_counter()
            update = learner.start(ppo_update, run.learner, run.optimizer, batches[cur], ppo, run.gen, run.lagrange)
            if overlapped:  # the next rollout while the update runs, by the weights from before it
                buffers[1 - cur].continue_from(buffers[cur], state.cpu())
                nxt = (1 - cur, *collect(actor, envs, buffers[1 - cur], state, run, cfg, d, device, heads, acts),
                       time.perf_counter() - t_learn)  # ..., the next rollout's seconds
                t_learn = time.perf_counter()  # from here, the wait for the update
                losses = update.result()
                actor.load_state_dict(policy.state_dict())
            else:
                losses = update.result()
                buffers[cur].after_update(state.cpu())
            t_learn = time.perf_counter() - t_learn
            run.env_steps += delta
            run.updates += 1
            t_update = time.perf_counter() - t0
            scalars = {"fps": delta / t_update, "fps_collect": delta / max(t_collect, 1e-9), **losses,
                       # shares of the update's time (train.overlap: the learner's share is what the envs waited for
                       # it; train.double_buffered: the envs' share is what the loop waited for them, acting meanwhile)
                       "time_envs": t_env / t_update, "time_learn": t_learn / t_update,
                       # 0 for an overlapped run's last update: its time holds no collection (its fps is the
                       # drain's), so steady-state figures leave it out
                       "overlapped": float(overlapped),
                       "updates": run.updates, "rollout_steps": delta / (n * d.world_size)}
            if run.lagrange is not None:
                scalars.update({"lambda": run.lagrange.value, "J_c": run.ep_cost})
            row = log.record(run.env_steps, sums, scalars)
            bar.update(delta)
            bar.set_postfix({k: f"{row[k]:.3g}" for k in ("reward", "goals", "lambda") if k in row})
            if d.rank == 0 and (run.updates % cfg.train.checkpoint_every == 0 or run.env_steps >= total):
                ck.save(out_dir, run.env_steps, policy, run.resume_state(), keep=cfg.train.keep_checkpoints)
            if not more:
                break
            t0 = time.perf_counter()
            if overlapped:  # collected while the update ran
                cur, state, episodes, t_env, delta, t_collect = nxt
            else:
                state, episodes, t_env, delta = collect(actor, envs, buffers[cur], state, run, cfg, d, device, heads, acts)
                t_collect = time.perf_counter() - t0
    finally:
        learner.close()
    bar.close()
    result = {"env_steps": run.env_steps, "updates": run.updates}
    if d.rank == 0:
        params = sum(p.numel() for p in policy.parameters())
        result["summary"] = summary(out_dir, cfg, run.env_steps - steps_start, time.perf_counter() - t_start, params)
        result.update(log.stats())
    return result
