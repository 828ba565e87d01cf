"""A rollout's collection (`collect`): ``ppo.num_steps`` steps of the policy acting on the envs' observations and the
envs stepping by its actions, into a `RolloutStorage`, then the rollout's GAE returns.

Plain, the policy acts for every env, then every env steps, in turn: an update's collection takes the acts' time plus
the envs'. With ``train.double_buffered`` (Sample Factory's double-buffered sampling) the env workers are two halves
(`ProcessBatchEnv.halves`), and while one half steps in its worker processes the policy acts for the other, so an
act's time hides behind the other half's step. Each env's transitions are the plain loop's: the halves are acted in
the plain loop's order (first half, then second, step by step), and a CPU draws the actions of two halves from one
generator as one draw for all (torch.multinomial's draws go row by row), so on a CPU the actions are the same to the
byte (tests/test_rl_double_buffered.py); a GPU's generator draws per call, so there the actions are other draws from
the same probabilities."""
from __future__ import annotations

import time

import numpy as np
import torch

from .distrib import all_sum
from .rollout import RolloutStorage, to_device


def collect(actor, envs, rollouts: RolloutStorage, state: torch.Tensor, run, cfg, d, device, heads: int,
            generator: torch.Generator | None = None) -> tuple:
    """A rollout of ``ppo.num_steps`` steps into ``rollouts`` (fewer when DD-PPO pre-empts it) acted by ``actor``
    (actions drawn from ``generator``, else torch's global one), and its GAE returns. Returns the recurrent state after
    it, the episodes that ended, the seconds the loop waited for the envs' steps and the env steps over all ranks."""
    ppo, n = cfg.ppo, envs.num_envs
    actor.eval()
    step_rollout = _double_buffered if cfg.train.double_buffered else _in_turn
    state, episodes, t_env = step_rollout(actor, envs, rollouts, state, run, cfg, d, device, heads, generator)
    d.rollout_done(run.updates)
    delta = int(all_sum(torch.tensor([float(rollouts.step * n)], dtype=torch.float64))[0])  # env steps, all ranks
    o, prev, masks = rollouts.current()
    with torch.no_grad():
        feats, _ = actor(to_device(o, device), state, prev.to(device), masks.to(device))
        next_values = actor.values(feats).cpu()
    rollouts.compute_returns(next_values, ppo.gamma, ppo.tau)
    return state, episodes, t_env, delta


def action_generator(seed: int, rank: int, updates: int, device) -> torch.Generator:
    """The actions' random stream of rank ``rank`` of a run of ``seed``, from its ``updates`` done: the ranks of DD-PPO
    draw apart (their weights start from one torch seed, as DistributedDataParallel needs), and a resumed run does
    not draw the fresh run's stream again. Not torch's global generator: torch.compile saves it and restores it after
    tracing (train.overlap's learner thread: the actor's draws made meanwhile were rewound)."""
    key = [seed, updates, 1] + ([rank] if rank else [])  # rank 0 (every one-process run): train.overlap's stream
    return torch.Generator(device=device).manual_seed(int(np.random.SeedSequence(key).generate_state(1)[0]))


def _rewards(reward: np.ndarray, cost: np.ndarray, heads: int) -> np.ndarray:
    return np.stack([reward, cost], -1) if heads == 2 else reward[:, None]


def _in_turn(actor, envs, rollouts, state, run, cfg, d, device, heads, generator) -> tuple:
    """The plain loop: every env's act, then every env's step."""
    ppo, episodes, t_env = cfg.ppo, [], 0.0
    for step in range(ppo.num_steps):
        o, prev, masks = rollouts.current()
        with torch.no_grad():
            action, logp, values, state = actor.act(to_device(o, device), state, prev.to(device), masks.to(device),
                                                    generator=generator)
        action = action.cpu()  # one copy to the host, for the envs and the storage
        t_step = time.perf_counter()
        obs, reward, cost, done, infos = envs.step(action.numpy())
        t_env += time.perf_counter() - t_step
        rollouts.insert(obs, action, logp.cpu(), values.cpu(), _rewards(reward, cost, heads), done)
        episodes += [info["episode"] for info in infos if "episode" in info]
        if d.should_end_early(step + 1, ppo.num_steps, run.updates, cfg.ddppo.sync_frac):
            break
    return state, episodes, t_env


def _double_buffered(actor, envs, rollouts, state, run, cfg, d, device, heads, generator) -> tuple:
    """train.double_buffered: each half's act for its next step while the other half steps. A half's step is sent
    (`send_step`) as soon as it is acted, and received (`recv_step`) when the loop comes back to it, after the other
    half's act; the rollout ends (its last step, or DD-PPO's pre-emption, asked once a step, after the first half's
    transition) with no step under way."""
    ppo, halves, episodes, t_env = cfg.ppo, envs.halves(), [], 0.0
    state = state.clone()  # written half by half
    acted: list[tuple | None] = [None, None]  # each half's (action, log-prob, values) on the CPU, its step under way

    def act(h: int, t: int) -> None:
        o, prev, masks = rollouts.inputs(t, halves[h])
        with torch.no_grad():
            action, logp, values, state[:, halves[h]] = actor.act(
                to_device(o, device), state[:, halves[h]], prev.to(device), masks.to(device), generator=generator)
        action = action.cpu()
        envs.send_step(action.numpy(), halves[h])
        acted[h] = (action, logp.cpu(), values.cpu())

    for h in range(len(halves)):
        act(h, rollouts.step)
    for step in range(ppo.num_steps):
        t, stop = rollouts.step, False
        for h, envs_h in enumerate(halves):
            t_wait = time.perf_counter()
            obs, reward, cost, done, infos = envs.recv_step(envs_h)
            t_env += time.perf_counter() - t_wait
            rollouts.insert(obs, *acted[h], _rewards(reward, cost, heads), done, envs=envs_h)
            episodes += [info["episode"] for info in infos if "episode" in info]
            if h == 0:
                stop = step + 1 == ppo.num_steps or d.should_end_early(step + 1, ppo.num_steps, run.updates,
                                                                        cfg.ddppo.sync_frac)
            if not stop:
                act(h, t + 1)
        rollouts.advance()
        if stop:
            break
    return state, episodes, t_env
