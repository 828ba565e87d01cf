"""The policy's LSTM over a rollout of T steps of N envs in which envs start new episodes
mid-way (mask 0 at the first step of an episode): the recurrent state restarts from zero
there and carries on everywhere else.

Every episode piece of every env becomes one sequence of a `PackedSequence`, so the LSTM
runs once per rollout, as habitat-baselines' ``rnn_state_encoder`` does
(``build_pack_info_from_dones``); a PPO update, which needs no final state, runs the pieces as
one padded batch instead (faster on a CPU, same outputs). The alternative, one LSTM call per
stretch between steps where any env restarts, pays a whole call per stretch: forward + backward
of the 2-layer, 512-wide LSTM over 2 envs x 64 steps took 49 ms with no restart and 326 ms with
32 on a 2-core CPU, against 40 and 55 ms padded (``benchmarks/rl_lstm.py``).
"""
from __future__ import annotations

import torch
from torch import nn
from torch.nn.utils.rnn import pack_padded_sequence, pad_packed_sequence


def episode_pieces(masks: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(env, first step, length) of every episode piece of ``masks`` [T, N], env-major:
    a piece starts at step 0 and wherever the mask is 0, and runs to the next start."""
    T = masks.size(0)
    starts = masks == 0
    starts[0] = True
    env, first = torch.nonzero(starts.t(), as_tuple=True)  # sorted by env, then step
    nxt = torch.full_like(first, T)
    same_env = env[1:] == env[:-1]
    nxt[:-1] = torch.where(same_env, first[1:], nxt[:-1])
    return env, first, nxt - first


def run_lstm(rnn: nn.LSTM, x: torch.Tensor, masks: torch.Tensor, h: torch.Tensor, c: torch.Tensor,
             need_state: bool = True):
    """``rnn`` (time-major) over ``x`` [T, N, F] from the state (h, c) [L, N, H], zeroed where
    ``masks`` [T, N] is 0. Returns (outputs [T, N, H], h_n, c_n) of each env's last step;
    with ``need_state=False`` (a PPO update) h_n and c_n are None and the pieces run as one
    padded batch, the fastest form on a CPU."""
    T, N = masks.shape
    masks = masks.to(x.device)
    if T == 1 or not bool((masks[1:] == 0).any()):  # one piece per env: a plain call
        keep = masks[0].view(1, -1, 1)
        out, (h, c) = rnn(x, (h * keep, c * keep))
        return out, h, c
    env, first, length = episode_pieces(masks.cpu())
    env_d, first_d = env.to(x.device), first.to(x.device)
    steps = torch.arange(int(length.max()), device=x.device)[:, None]  # [Lmax, 1]
    t = (first_d[None] + steps).clamp(max=T - 1)  # [Lmax, S]; past a piece's end: padding
    padded = x[t, env_d[None].expand_as(t)]  # [Lmax, S, F]
    carry = (masks[0, env_d] * (first_d == 0)).view(1, -1, 1)  # only a piece at step 0 continues (h, c)
    h0, c0 = h[:, env_d] * carry, c[:, env_d] * carry
    if need_state:  # packed: the LSTM stops at each piece's end, so (h_n, c_n) are the pieces' last states
        out, (h_n, c_n) = rnn(pack_padded_sequence(padded, length, enforce_sorted=False), (h0, c0))
        out, _ = pad_packed_sequence(out, total_length=steps.size(0))  # [Lmax, S, H]
    else:  # padded: steps past a piece's end come after its outputs, which they cannot change
        out, _ = rnn(padded, (h0, c0))
    valid = (steps < length.to(x.device)[None])  # [Lmax, S]
    rows = out[valid]  # [T * N, H], ordered by (step in piece, piece)
    out = rows[torch.argsort((t * N + env_d[None])[valid])].view(T, N, -1)  # back to time-major (t, env)
    if not need_state:
        return out, None, None
    last = torch.ones_like(env, dtype=torch.bool)
    last[:-1] = env[1:] != env[:-1]  # each env's last piece, in env order
    last = last.to(x.device)
    return out, h_n[:, last], c_n[:, last]
