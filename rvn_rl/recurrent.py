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

Which steps form which piece depends on the masks' values. Read from a GPU tensor, they make the host wait for the
GPU (three times a call); a PPO update's mini-batches therefore carry their plan (`Pieces`), computed from the
rollout's masks on the CPU (`rollout.DeviceRollouts`).
"""
from __future__ import annotations

from typing import NamedTuple

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


class Pieces(NamedTuple):
    """`run_lstm`'s index plan of the padded pass over masks [T, N]: S episode pieces, padded to the longest (Lmax
    steps). `plan_pieces` computes it from masks on the CPU, so that a PPO update on a GPU (`DeviceRollouts`) gathers
    its pieces without the host waiting for the GPU: run from the masks alone, `run_lstm` reads their values on the
    host three times (whether any env restarts, the pieces, and the boolean selection of the outputs)."""

    t: torch.Tensor  # [Lmax, S] the step each padded row reads (past a piece's end: its last step, padding)
    env: torch.Tensor  # [S] each piece's env
    carry: torch.Tensor  # [1, S, 1] 1 for a piece at step 0 whose mask is 1 (it continues the state (h, c)), else 0
    rows: torch.Tensor  # [T * N] the padded output's flat row (of Lmax * S) of each (step, env), time-major

    def to(self, device, non_blocking: bool = False) -> "Pieces":
        return Pieces(*(p.to(device, non_blocking=non_blocking) for p in self))


def _plan(masks: torch.Tensor) -> tuple[Pieces, torch.Tensor, torch.Tensor]:
    """(plan, env, length) of the CPU tensor ``masks`` [T, N]: `Pieces`, and `episode_pieces`'s env and length."""
    T, N = masks.shape
    env, first, length = episode_pieces(masks)
    steps = torch.arange(int(length.max()))[:, None]  # [Lmax, 1]
    t = (first[None] + steps).clamp(max=T - 1)  # [Lmax, S]
    carry = (masks[0, env] * (first == 0)).view(1, -1, 1)  # only a piece at step 0 continues (h, c)
    valid = steps < length[None]  # [Lmax, S]
    flat = torch.nonzero(valid.reshape(-1)).squeeze(1)  # valid rows, ordered by (step in piece, piece)
    rows = flat[torch.argsort((t * N + env[None])[valid])]  # ... reordered time-major (t, env)
    return Pieces(t, env, carry, rows), env, length


def plan_pieces(masks: torch.Tensor, device=None) -> Pieces:
    """The plan of ``masks`` [T, N] (a CPU tensor), moved to ``device`` without waiting (non-blocking copies)."""
    plan = _plan(masks)[0]
    return plan if device is None else plan.to(device, non_blocking=True)


def run_lstm(rnn: nn.LSTM, x: torch.Tensor, masks: torch.Tensor, h: torch.Tensor, c: torch.Tensor,
             need_state: bool = True, pieces: Pieces | None = None):
    """``rnn`` (time-major) over ``x`` [T, N, F] from the state (h, c) [L, N, H], zeroed where
    ``masks`` [T, N] is 0. Returns (outputs [T, N, H], h_n, c_n) of each env's last step;
    with ``need_state=False`` (a PPO update) h_n and c_n are None and the pieces run as one
    padded batch, the fastest form on a CPU. ``pieces``, `plan_pieces` of the same masks (need_state=False only),
    runs the padded batch without reading the masks on the host; the same outputs bit for bit."""
    T, N = masks.shape
    if pieces is None:
        masks = masks.to(x.device)
        if T == 1 or not bool((masks[1:] == 0).any()):  # one piece per env: a plain call
            keep = masks[0].view(1, -1, 1)
            out, (h, c) = rnn(x, (h * keep, c * keep))
            return out, h, c
        plan, env_cpu, length = _plan(masks.cpu())
        pieces = plan.to(x.device)
    elif need_state:
        raise ValueError("run_lstm: a plan of pieces is for a PPO update's pass, which needs no state "
                         "(need_state=False)")
    t, env, carry, rows = pieces
    padded = x[t, env[None].expand_as(t)]  # [Lmax, S, F]
    h0, c0 = h[:, env] * carry, c[:, env] * carry
    if need_state:  # packed: the LSTM stops at each piece's end, so (h_n, c_n) are the pieces' last states
        out, (h_n, c_n) = rnn(pack_padded_sequence(padded, length, enforce_sorted=False), (h0, c0))
        out, _ = pad_packed_sequence(out, total_length=t.size(0))  # [Lmax, S, H]
    else:  # padded: steps past a piece's end come after its outputs, which they cannot change
        out, _ = rnn(padded, (h0, c0))
    out = out.reshape(-1, out.size(-1))[rows].view(T, N, -1)  # back to time-major (t, env)
    if not need_state:
        return out, None, None
    last = torch.ones_like(env_cpu, dtype=torch.bool)
    last[:-1] = env_cpu[1:] != env_cpu[:-1]  # each env's last piece, in env order
    last = last.to(x.device)
    return out, h_n[:, last], c_n[:, last]
