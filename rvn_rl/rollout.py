"""Rollout storage for recurrent PPO with GAE over one or two value heads (reward, and cost
for PPO-Lagrangian). Rollouts may end early (DD-PPO's straggler pre-emption): only the
first ``step`` transitions are used. `DeviceRollouts` hands the update its mini-batches on the learner's device, each
with the plan of its LSTM pass (`recurrent.Pieces`)."""
from __future__ import annotations

import numpy as np
import torch

from .recurrent import plan_pieces


class RolloutStorage:
    def __init__(self, num_steps: int, num_envs: int, obs_space: dict, state_shape: tuple, heads: int):
        T, N = num_steps, num_envs
        self.num_steps, self.num_envs, self.heads = T, N, heads
        self.obs = {k: torch.zeros((T + 1, N, *shape), dtype=dtype) for k, (shape, dtype) in obs_space.items()}
        self.state0 = torch.zeros(state_shape)
        self.prev_actions = torch.zeros(T + 1, N, dtype=torch.long)
        self.masks = torch.zeros(T + 1, N)
        self.actions = torch.zeros(T, N, dtype=torch.long)
        self.logp = torch.zeros(T, N)
        self.values = torch.zeros(T + 1, N, heads)
        self.rewards = torch.zeros(T, N, heads)
        self.returns = torch.zeros(T + 1, N, heads)
        self.step = 0

    def set_first(self, obs: dict, state: torch.Tensor, prev_actions: torch.Tensor, masks: torch.Tensor) -> None:
        for k, v in obs.items():
            self.obs[k][0].copy_(torch.as_tensor(v))
        self.state0.copy_(state)
        self.prev_actions[0].copy_(prev_actions)
        self.masks[0].copy_(masks)
        self.step = 0

    def current(self) -> tuple[dict, torch.Tensor, torch.Tensor]:
        """Every env's acting inputs (observation, previous action, mask) at the current step."""
        return self.inputs(self.step)

    def inputs(self, t: int, envs: slice = slice(None)) -> tuple[dict, torch.Tensor, torch.Tensor]:
        """The acting inputs of the envs ``envs`` (train.double_buffered's half) at step ``t``."""
        return {k: v[t, envs] for k, v in self.obs.items()}, self.prev_actions[t, envs], self.masks[t, envs]

    def insert(self, obs: dict, actions, logp, values, rewards, done: np.ndarray, envs: slice | None = None) -> None:
        """Transition ``step`` (its action, log-prob, value, rewards [N, heads]) and the next observation; ``done``
        marks envs whose episode ended with this action. With ``envs`` (a slice: train.double_buffered's half), those
        envs' columns only, and the step stays: `advance` once every env's transition is in."""
        t, cols = self.step, slice(None) if envs is None else envs
        self.actions[t, cols].copy_(actions)
        self.logp[t, cols].copy_(logp)
        self.values[t, cols].copy_(values)
        self.rewards[t, cols].copy_(torch.as_tensor(rewards))
        for k, v in obs.items():
            self.obs[k][t + 1, cols].copy_(torch.as_tensor(v))
        self.prev_actions[t + 1, cols].copy_(actions)
        self.masks[t + 1, cols].copy_(torch.as_tensor(~done, dtype=torch.float32))
        if envs is None:
            self.advance()

    def advance(self) -> None:
        self.step += 1

    def compute_returns(self, next_values: torch.Tensor, gamma: float, tau: float) -> torch.Tensor:
        """GAE(gamma, tau) returns per head; returns the advantages [step, N, heads]."""
        n = self.step
        self.values[n].copy_(next_values)
        gae = torch.zeros(self.num_envs, self.heads)
        adv = torch.zeros(n, self.num_envs, self.heads)
        for t in reversed(range(n)):
            m = self.masks[t + 1].unsqueeze(-1)
            delta = self.rewards[t] + gamma * self.values[t + 1] * m - self.values[t]
            gae = delta + gamma * tau * m * gae
            adv[t] = gae
        self.returns[:n] = adv + self.values[:n]
        return adv

    def after_update(self, state: torch.Tensor) -> None:
        """Carry the last observation, state, previous action and mask to the next rollout."""
        self.continue_from(self, state)

    def continue_from(self, other: "RolloutStorage", state: torch.Tensor) -> None:
        """Start a rollout where ``other``'s ended: its last observation, previous action and mask, and ``state``
        (train.overlap collects into one storage while the update reads the other)."""
        n = other.step
        for k, v in self.obs.items():
            v[0].copy_(other.obs[k][n])
        self.prev_actions[0].copy_(other.prev_actions[n])
        self.masks[0].copy_(other.masks[n])
        self.state0.copy_(state)
        self.step = 0


def to_device(obs: dict, device) -> dict:
    """A batch of observations (arrays or tensors) as tensors on ``device``."""
    return {k: torch.as_tensor(v).to(device, non_blocking=True) for k, v in obs.items()}


_FIELDS = ("prev_actions", "masks", "actions", "logp", "values", "returns")  # per step and env, besides obs


class DeviceRollouts:
    """The PPO update's mini-batches of a CPU `RolloutStorage`, on the learner's device: each the whole rollout of a
    random subset of envs (time-major, flat). The filled part of the rollout moves to the device once per update (at
    the first `minibatches` call with a new ``advantages``) and every epoch's mini-batches are gathered there, instead
    of each mini-batch being gathered on the CPU and copied over (scale=small on 30 envs: 4 epochs x 4 mini-batches
    of ~24 MB of frames an update)."""

    def __init__(self, rollouts: RolloutStorage, device, plans: bool = True):
        """``plans=False``: mini-batches without their plan of pieces (None), so that the LSTM reads the masks on the
        host, as before the plans (for comparison: benchmarks/rl_lstm.py --update, the tests)."""
        self.r, self.device, self.plans = rollouts, torch.device(device), plans
        self.returns, self.values = rollouts.returns, rollouts.values
        self._adv, self._on_device = None, None

    @property
    def step(self) -> int:
        return self.r.step

    def _load(self, adv: torch.Tensor) -> dict:
        r, n, dev = self.r, self.r.step, self.device
        return {"obs": {k: v[:n].to(dev) for k, v in r.obs.items()}, "state": r.state0.to(dev),
                **{k: getattr(r, k)[:n].to(dev) for k in _FIELDS}, "advantages": adv.to(dev)}

    def _on(self, adv: torch.Tensor) -> dict:
        if adv is not self._adv:  # a new update (holding the last one's advantages, no new tensor can be them)
            self._adv, self._on_device = adv, self._load(adv)
        return self._on_device

    def _envs(self, d: dict, env: torch.Tensor) -> dict:
        """The mini-batch of the envs ``env``: their whole rollouts, time-major and flat."""
        n = self.r.step
        pieces = plan_pieces(self.r.masks[:n, env], self.device) if self.plans else None  # from the CPU's masks
        idx = env.to(self.device, non_blocking=True)

        def flat(x: torch.Tensor) -> torch.Tensor:
            return x[:, idx].reshape(n * len(idx), *x.shape[2:])
        keys = (*_FIELDS, "advantages", *(["prox_logp"] if "prox_logp" in d else []))
        return {"obs": {k: flat(v) for k, v in d["obs"].items()}, "state": d["state"][:, idx],
                **{k: flat(d[k]) for k in keys}, "pieces": pieces}

    def minibatches(self, adv: torch.Tensor, num_mini_batch: int, generator: torch.Generator):
        d = self._on(adv)
        perm = torch.randperm(self.r.num_envs, generator=generator)
        for env in torch.tensor_split(perm, num_mini_batch):  # exactly num_mini_batch, at most one env apart
            yield self._envs(d, env)

    def start_policy(self, model, chunks: int) -> tuple[torch.Tensor, torch.Tensor]:
        """The rollout under ``model`` as it is at the update's start: one forward pass over its n + 1 steps (the
        bootstrap's included), in eval mode (as the actor acts: the input normaliser's statistics stay), without
        gradients, over ``chunks`` groups of envs in order. Returns the log-probs of the rollout's actions [n, N] on
        the learner's device (`set_proximal`) and the values [n + 1, N, heads] on the CPU (`use_values`); the LSTM is
        causal, so step n, which acts after the rollout, changes neither."""
        r, n, dev = self.r, self.r.step, self.device
        logp, values = torch.empty(n + 1, r.num_envs, device=dev), torch.empty(n + 1, r.num_envs, r.heads)
        actions = torch.cat([r.actions[:n], r.actions[:1]])  # step n's action: any (its log-prob is dropped)
        training = model.training
        model.eval()
        try:
            with torch.no_grad():
                for env in torch.arange(r.num_envs).chunk(chunks):
                    def flat(x: torch.Tensor) -> torch.Tensor:
                        return x[:n + 1, env].reshape((n + 1) * len(env), *x.shape[2:]).to(dev)
                    pieces = plan_pieces(r.masks[:n + 1, env], dev) if self.plans else None
                    lp, _, v = model({k: flat(val) for k, val in r.obs.items()}, r.state0[:, env].to(dev),
                                     flat(r.prev_actions), flat(r.masks), flat(actions), pieces=pieces)
                    logp[:, env.to(dev)] = lp.float().view(n + 1, len(env))
                    values[:, env] = v.float().view(n + 1, len(env), r.heads).cpu()
        finally:
            model.train(training)
        return logp[:n], values

    def use_values(self, values: torch.Tensor, gamma: float, tau: float) -> None:
        """`ppo.recompute_advantages`: ``values`` [n + 1, N, heads] (`start_policy`'s) in place of those the acting
        weights gave, the bootstrap after the rollout's last step included, and the GAE returns again from them."""
        n = self.r.step
        self.r.values[:n].copy_(values[:n])
        self.r.compute_returns(values[n], gamma, tau)

    def set_proximal(self, adv: torch.Tensor, logp: torch.Tensor) -> None:
        """Decoupled PPO's proximal policy (`ppo.decoupled`): ``logp`` [n, N] (`start_policy`'s), which this update's
        mini-batches (those of ``adv``) then carry as ``prox_logp``."""
        self._on(adv)["prox_logp"] = logp
