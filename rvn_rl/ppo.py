"""Recurrent PPO update (clipped surrogate, clipped value loss, entropy bonus, gradient-norm
clipping) as habitat-baselines' PPO, and the PPO-Lagrangian multiplier as OmniSafe's
`Lagrange`: Adam on -lambda (J_c - d), lambda clamped to >= 0, surrogate advantage
(A_r - lambda A_c) / (1 + lambda).

``ppo.decoupled``: decoupled PPO (Hilton et al. 2021, "Batch size-invariance for policy optimization") for rollouts
acted by older weights (train.overlap): the surrogate's ratio is to the proximal policy, the weights at the update's
start (`DeviceRollouts.start_policy`), and each advantage is weighted by the proximal / behaviour ratio.
``ppo.recompute_advantages``: the rollout's values (and so GAE's advantages, the value targets and the clipped value
loss's anchor) recomputed with the weights at the update's start (the same pass), instead of the
acting weights' (with train.overlap one update older); Andrychowicz et al. 2021 ("What matters in on-policy RL")
recompute them before every epoch."""
from __future__ import annotations

import torch
from torch import nn

from .distrib import all_sum
from .settings import PPOConfig  # the ``ppo`` settings (defined there so that the schema imports no torch)


class Lagrange:
    """lambda >= 0 learned from the mean episode cost J_c against the limit d."""

    def __init__(self, cost_limit: float, init: float = 0.001, lr: float = 0.035, upper_bound: float | None = None):
        self.cost_limit = float(cost_limit)
        self.upper_bound = upper_bound
        self.multiplier = nn.Parameter(torch.tensor(float(init)))
        self.optimizer = torch.optim.Adam([self.multiplier], lr=lr)

    @property
    def value(self) -> float:
        return float(self.multiplier.detach())

    def update(self, ep_cost: float) -> None:
        self.optimizer.zero_grad()
        loss = -self.multiplier * (ep_cost - self.cost_limit)
        loss.backward()
        self.optimizer.step()
        self.multiplier.data.clamp_(0.0, self.upper_bound if self.upper_bound is not None else float("inf"))

    def state_dict(self) -> dict:
        return {"multiplier": self.multiplier.detach().clone(), "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        """The multiplier and Adam's moments of ``state``; the learning rate stays this one's (a resumed run's
        algo.lambda_lr, not its checkpoint's)."""
        lr = self.optimizer.param_groups[0]["lr"]
        self.multiplier.data.copy_(state["multiplier"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.optimizer.param_groups[0]["lr"] = lr


def normalise(adv: torch.Tensor) -> torch.Tensor:
    """Advantages standardised with mean/variance over every rank's rollout."""
    stats = all_sum(torch.stack([adv.sum(), adv.pow(2).sum(), torch.tensor(float(adv.numel()))]).double())
    mean = stats[0] / stats[2]
    var = (stats[1] / stats[2] - mean ** 2).clamp(min=0.0)
    return ((adv - mean) / (var.sqrt() + 1e-5)).float()


def ppo_update(model: nn.Module, optimizer, rollouts, cfg: PPOConfig, generator: torch.Generator,
               lagrange: Lagrange | None = None) -> dict:
    """One PPO update over the filled part of ``rollouts`` (returns computed already).
    ``model`` may be a DistributedDataParallel wrapper (gradients all-reduced in backward)."""
    if cfg.recompute_advantages or cfg.decoupled:  # one pass of the weights this update starts from serves both
        start_logp, start_values = rollouts.start_policy(model, cfg.num_mini_batch)
    if cfg.recompute_advantages:  # the values behind GAE from the weights this update starts from
        rollouts.use_values(start_values, cfg.gamma, cfg.tau)
    adv = rollouts.returns[:rollouts.step] - rollouts.values[:rollouts.step]
    if lagrange is not None:
        lam = lagrange.value
        adv = (adv[..., 0] - lam * adv[..., 1]) / (1.0 + lam)
    else:
        adv = adv[..., 0]
    if cfg.use_normalized_advantage:
        adv = normalise(adv)
    if cfg.decoupled:  # clip around the policy at this update's start, weighted by its ratio to the one that acted
        rollouts.set_proximal(adv, start_logp)
    names = ("value_loss", "action_loss", "entropy", "grad_norm")
    sums, updates = None, 0  # summed on the learner's device (float64, as Python's floats): one host sync an update
    for _ in range(cfg.ppo_epoch):
        for mb in rollouts.minibatches(adv, cfg.num_mini_batch, generator):
            logp, entropy, values = model(mb["obs"], mb["state"], mb["prev_actions"], mb["masks"], mb["actions"],
                                          pieces=mb["pieces"])
            a = mb["advantages"]
            if cfg.decoupled:
                ratio = torch.exp(logp - mb["prox_logp"])
                a = a * torch.exp(mb["prox_logp"] - mb["logp"])  # importance weight proximal / behaviour (> 0)
            else:
                ratio = torch.exp(logp - mb["logp"])
            action_loss = -torch.min(ratio * a, ratio.clamp(1 - cfg.clip_param, 1 + cfg.clip_param) * a).mean()
            ret, old = mb["returns"], mb["values"]
            if cfg.use_clipped_value_loss:
                clipped = old + (values - old).clamp(-cfg.clip_param, cfg.clip_param)
                value_loss = 0.5 * torch.max((values - ret).pow(2), (clipped - ret).pow(2)).sum(-1).mean()
            else:
                value_loss = 0.5 * (values - ret).pow(2).sum(-1).mean()
            entropy = entropy.mean()
            loss = value_loss * cfg.value_loss_coef + action_loss - entropy * cfg.entropy_coef
            optimizer.zero_grad()
            loss.backward()
            grad_norm = nn.utils.clip_grad_norm_(model.parameters(), cfg.max_grad_norm)
            optimizer.step()
            terms = torch.stack([value_loss.detach(), action_loss.detach(), entropy.detach(), grad_norm]).double()
            sums = terms if sums is None else sums + terms
            updates += 1
    totals = sums.tolist() if sums is not None else [0.0] * len(names)
    return {k: v / max(1, updates) for k, v in zip(names, totals)}
