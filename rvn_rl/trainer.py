"""The rvn-rl training loop: collect a rollout of ``ppo.num_steps`` steps from a `BatchEnv`
(DD-PPO ranks may stop early once ``ddppo.sync_frac`` of the ranks finished), GAE, a PPO
update through a DistributedDataParallel replica when distributed, the Lagrange multiplier
for PPO-Lagrangian, logging and resumable checkpoints in ``out_dir``."""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np
import torch
import yaml
from torch import nn

from rvn_data.cli.common import check_writable_dir, validating
from rvn_data.numba_note import note_first_compile
from rvn_data.provenance import provenance_record

from . import checkpoint as ck
from .config import RLConfig
from .distrib import Dist, all_sum, init
from .model import PointNavResNetPolicy
from .ppo import Lagrange, ppo_update
from .rollout import RolloutStorage
from .runlog import RunLog, episode_sums, plot_learning_curve, summary
from .vec_env import BatchEnv


class _Evaluate(nn.Module):
    """Forward = the policy's ``evaluate`` (what DistributedDataParallel wraps)."""

    def __init__(self, policy: PointNavResNetPolicy):
        super().__init__()
        self.policy = policy

    def forward(self, obs, state, prev_actions, masks, actions):
        return self.policy.evaluate(obs, state, prev_actions, masks, actions)


def pick_device(setting: str, d: Dist) -> torch.device:
    if setting == "auto":
        setting = "cuda" if torch.cuda.is_available() else "cpu"
    if setting.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ValueError(f"device={setting}: this torch finds no GPU; use device=cpu or auto")
        return torch.device("cuda", d.local_rank if d.enabled else torch.device(setting).index or 0)
    if setting != "cpu":
        raise ValueError(f"device={setting!r}: choose auto, cpu or cuda")
    return torch.device("cpu")


def make_envs(cfg: RLConfig, seed: int, rank: int = 0, device="cpu"):
    """The run's environments: in this process (``env.workers=0``) or split over worker processes;
    predicted depth (algo=ddppo_depth, depth.source=model) runs on ``device``."""
    depth_fn = None
    if cfg.uses_predicted_depth:
        from .depth import load_depth_model
        depth_fn = load_depth_model(str(cfg.depth.model_path), device=device)
    common = dict(seed=seed, rank=rank, scene_cache=cfg.env.scene_cache, depth_fn=depth_fn)
    if cfg.env.workers:
        from .vec_procs import ProcessBatchEnv
        return ProcessBatchEnv(cfg.env_kwargs(), cfg.env.num_envs, cfg.env.workers, **common)
    return BatchEnv(cfg.env_kwargs(), cfg.env.num_envs, **common)


def _check_out_dir(out_dir: Path, cfg: RLConfig) -> Path | None:
    """The checkpoint to resume from (or None); refuses an out_dir of another run or kind."""
    if not (out_dir / "config.yaml").is_file():
        return None
    old = ck.read_rl_config(out_dir)
    if old["policy"] != cfg.model_kwargs() or old["algo"]["name"] != cfg.algo.name:
        raise ValueError(f"out_dir={out_dir} holds another run ({old['algo']['name']}, {old['policy']['backbone']}, "
                         f"{old['policy']['obs_size']}px); choose a new out_dir")
    return ck.latest(out_dir) if cfg.train.resume else None


def train(cfg: RLConfig, on_checked=None) -> dict:
    """Train; settings, device and out_dir are checked first (`ConfigError`, nothing written),
    then ``on_checked()`` runs."""
    d = init(cfg.ddppo.backend, "cuda" if cfg.device.startswith("cuda") or
             (cfg.device == "auto" and torch.cuda.is_available()) else "cpu")
    try:
        return _train(cfg, d, on_checked)
    finally:
        from .distrib import shutdown
        shutdown()


def _train(cfg: RLConfig, d: Dist, on_checked=None) -> dict:
    with validating():
        cfg.validate(d.world_size)
        device = pick_device(cfg.device, d)
        out_dir = check_writable_dir(Path(cfg.out_dir).expanduser())
        resume_from = _check_out_dir(out_dir, cfg)
    if on_checked is not None:
        on_checked()
    if cfg.train.threads:
        torch.set_num_threads(cfg.train.threads)
    ppo, lag = cfg.ppo, cfg.algo
    torch.manual_seed(cfg.seed)  # identical initial weights on every rank
    policy = PointNavResNetPolicy(**cfg.model_kwargs()).to(device)
    optimizer = torch.optim.Adam(policy.parameters(), lr=ppo.lr, eps=ppo.eps)
    lagrange = Lagrange(lag.cost_limit, lag.lambda_init, lag.lambda_lr, lag.lambda_max) if lag.lagrangian else None
    env_steps, updates, ep_cost = 0, 0, 0.0
    if resume_from is not None:
        ck.load_weights(policy, resume_from)
        state = ck.load_state(resume_from)
        optimizer.load_state_dict(state["optimizer"])
        env_steps, updates, ep_cost = state["env_steps"], state["updates"], state.get("ep_cost", 0.0)
        if lagrange is not None:
            lagrange.load_state_dict(state["lagrange"])
    if d.rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
        earlier = yaml.safe_load((out_dir / "config.yaml").read_text()) if (out_dir / "config.yaml").is_file() else None
        ck.write_config(out_dir, {**cfg.record(), "policy": cfg.model_kwargs(),
                                  **provenance_record(earlier if isinstance(earlier, dict) else None, resume_from is not None)})
    learner = _Evaluate(policy)
    if d.enabled:
        from torch.nn.parallel import DistributedDataParallel as DDP
        learner = DDP(learner, device_ids=[device.index] if device.type == "cuda" else None,
                      broadcast_buffers=False, find_unused_parameters=False, gradient_as_bucket_view=True)
    gen = torch.Generator().manual_seed(int(np.random.SeedSequence([cfg.seed, d.rank, updates]).generate_state(1)[0]))
    if d.rank == 0:
        note_first_compile("rvn-rl")
    envs = make_envs(cfg, seed=cfg.seed + 7919 * updates, rank=d.rank, device=device)
    logging.getLogger("rvn").setLevel(logging.WARNING)  # the first scenes' renderer lines are enough
    log = RunLog(out_dir, d.rank == 0)
    try:
        return _loop(cfg, d, device, policy, learner, optimizer, lagrange, ppo, envs, log, gen,
                     env_steps, updates, ep_cost, out_dir)
    finally:
        envs.close()
        log.close()


def _to(obs: dict, device) -> dict:
    return {k: torch.as_tensor(v).to(device, non_blocking=True) for k, v in obs.items()}


def _loop(cfg, d, device, policy, learner, optimizer, lagrange, ppo, envs, log, gen, env_steps, updates, ep_cost,
          out_dir):
    from tqdm import tqdm

    n = envs.num_envs
    obs = envs.reset()
    space = {k: (v.shape[1:], torch.uint8 if v.dtype == np.uint8 else torch.float32) for k, v in obs.items()}
    heads = 2 if lagrange is not None else 1
    state = policy.initial_state(n, device)
    rollouts = RolloutStorage(ppo.num_steps, n, space, tuple(state.shape), heads)
    rollouts.set_first(obs, state.cpu(), torch.zeros(n, dtype=torch.long), torch.zeros(n))
    total = cfg.train.total_steps
    bar = tqdm(total=total, initial=min(env_steps, total), unit="step", desc=f"rvn-rl {cfg.algo.name}",
               disable=d.rank != 0 or not cfg.progress, smoothing=0.1)
    t_start, steps_start = time.perf_counter(), env_steps
    params = sum(p.numel() for p in policy.parameters())
    while env_steps < total:
        t0 = time.perf_counter()
        policy.eval()
        episodes = []
        for step in range(ppo.num_steps):
            o, prev, masks = rollouts.current()
            with torch.no_grad():
                action, logp, values, state = policy.act(_to(o, device), state, prev.to(device), masks.to(device),
                                                         generator=None)
            obs, reward, cost, done, infos = envs.step(action.cpu().numpy())
            rewards = np.stack([reward, cost], -1) if heads == 2 else reward[:, None]
            rollouts.insert(obs, action.cpu(), logp.cpu(), values.cpu(), rewards, done)
            episodes += [info["episode"] for info in infos if "episode" in info]
            if d.should_end_early(step + 1, ppo.num_steps, updates, cfg.ddppo.sync_frac):
                break
        d.rollout_done(updates)
        t_collect = time.perf_counter() - t0
        o, prev, masks = rollouts.current()
        with torch.no_grad():
            feats, _ = policy(_to(o, device), state, prev.to(device), masks.to(device))
            next_values = policy.values(feats).cpu()
        rollouts.compute_returns(next_values, ppo.gamma, ppo.tau)
        sums = episode_sums(episodes)
        if lagrange is not None:
            if sums[0] > 0:
                ep_cost = float(sums[6] / sums[0])
            lagrange.update(ep_cost)
        policy.train()
        losses = ppo_update(learner, optimizer, _DeviceRollouts(rollouts, device), ppo, gen, lagrange)
        delta = int(all_sum(torch.tensor([float(rollouts.step * n)], dtype=torch.float64))[0])
        rollouts.after_update(state.cpu())
        env_steps += delta
        updates += 1
        now = time.perf_counter()
        scalars = {"fps": delta / (now - t0), "fps_collect": delta / max(t_collect, 1e-9), **losses,
                   "updates": updates, "rollout_steps": delta / (n * d.world_size)}
        if lagrange is not None:
            scalars.update({"lambda": lagrange.value, "J_c": ep_cost})
        row = log.record(env_steps, sums, scalars)
        bar.update(delta)
        bar.set_postfix({k: f"{row[k]:.3g}" for k in ("reward", "goals", "lambda") if k in row})
        if d.rank == 0 and (updates % cfg.train.checkpoint_every == 0 or env_steps >= total):
            _save(out_dir, cfg, policy, optimizer, lagrange, env_steps, updates, ep_cost)
    bar.close()
    seconds = time.perf_counter() - t_start
    result = {"env_steps": env_steps, "updates": updates}
    if d.rank == 0:
        if updates and ck.latest(out_dir) is None:
            _save(out_dir, cfg, policy, optimizer, lagrange, env_steps, updates, ep_cost)
        plot_learning_curve(out_dir, f"rvn-rl {cfg.algo.name}")
        result["summary"] = summary(out_dir, cfg, env_steps - steps_start, seconds, params)
        result.update(log.stats())
    return result


class _DeviceRollouts:
    """Mini-batches of a CPU `RolloutStorage` moved to the learner's device."""

    def __init__(self, rollouts: RolloutStorage, device):
        self.r, self.device = rollouts, device
        self.step, self.returns, self.values = rollouts.step, rollouts.returns, rollouts.values

    def minibatches(self, adv, num_mini_batch, generator):
        for mb in self.r.minibatches(adv, num_mini_batch, generator):
            yield {k: (_to(v, self.device) if isinstance(v, dict) else v.to(self.device)) for k, v in mb.items()}


def _save(out_dir, cfg, policy, optimizer, lagrange, env_steps, updates, ep_cost) -> None:
    state = {"optimizer": optimizer.state_dict(), "env_steps": env_steps, "updates": updates, "ep_cost": ep_cost}
    if lagrange is not None:
        state["lagrange"] = lagrange.state_dict()
    ck.save(out_dir, env_steps, policy, state, keep=cfg.train.keep_checkpoints)
