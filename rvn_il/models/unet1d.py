"""Conditional 1-D U-Net noise predictor, as ConditionalUnet1D of real-stanford/diffusion_policy
(the one NoMaD uses): residual Conv1d blocks with GroupNorm and Mish, a bias-only FiLM term
from [sinusoidal timestep embedding → MLP, global condition], stride-2 down/up sampling with
skip connections. Input and output are [B, horizon, input_dim].

:meth:`ConditionalUnet1D.forward_packed` computes the same function for inference: every
convolution becomes one matrix product over all B·horizon positions (im2col on the
[B, horizon, C] rows) with weights repacked once and cached until a parameter changes. On a
CPU this avoids most of ``nn.Conv1d``'s per-call cost, which dominates for the short sequences
and small batches of a policy's sampling loop; the values agree with ``forward`` to float
rounding.
"""
from __future__ import annotations

import math
from typing import Sequence

import torch
import torch.nn.functional as F
from torch import nn

from .packing import packed_cache


class SinusoidalPosEmb(nn.Module):
    def __init__(self, dim: int):
        super().__init__()
        self.dim = dim

    def forward(self, t: torch.Tensor) -> torch.Tensor:
        half = self.dim // 2
        freq = torch.exp(torch.arange(half, device=t.device) * (-math.log(10000) / (half - 1)))
        x = t.float()[:, None] * freq[None, :]
        return torch.cat([x.sin(), x.cos()], dim=-1)


class Conv1dBlock(nn.Sequential):
    """Conv1d → GroupNorm → Mish."""

    def __init__(self, c_in: int, c_out: int, kernel_size: int, n_groups: int = 8):
        super().__init__(nn.Conv1d(c_in, c_out, kernel_size, padding=kernel_size // 2),
                         nn.GroupNorm(n_groups, c_out), nn.Mish())


class ConditionalResidualBlock1D(nn.Module):
    def __init__(self, c_in: int, c_out: int, cond_dim: int, kernel_size: int = 3, n_groups: int = 8):
        super().__init__()
        self.blocks = nn.ModuleList([Conv1dBlock(c_in, c_out, kernel_size, n_groups),
                                     Conv1dBlock(c_out, c_out, kernel_size, n_groups)])
        self.cond_encoder = nn.Sequential(nn.Mish(), nn.Linear(cond_dim, c_out))  # FiLM bias
        self.residual_conv = nn.Conv1d(c_in, c_out, 1) if c_in != c_out else nn.Identity()

    def forward(self, x: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
        """x [B,C_in,T], bias [B or 1, C_out, 1] = ``cond_encoder(cond)[..., None]`` (FiLM)."""
        out = self.blocks[0](x) + bias
        return self.blocks[1](out) + self.residual_conv(x)


def _bias(conv: nn.Module, n: int) -> torch.Tensor:
    return conv.bias.detach() if conv.bias is not None else conv.weight.new_zeros(n)


def _pack_conv(conv: nn.Conv1d) -> tuple:
    """(weight [k·C_in, C_out] with row kk·C_in + c, bias, kernel, stride, padding) of a Conv1d."""
    w = conv.weight.detach()
    k = w.shape[2]
    if conv.dilation[0] != 1 or conv.groups != 1 or not isinstance(conv.padding[0], int):
        raise ValueError(f"forward_packed supports plain Conv1d only, not {conv}")
    return (w.permute(2, 1, 0).reshape(k * w.shape[1], w.shape[0]).contiguous(), _bias(conv, w.shape[0]), k,
            conv.stride[0], conv.padding[0])


def _conv_rows(x: torch.Tensor, packed: tuple) -> torch.Tensor:
    """Conv1d on rows x [B,T,C] (any strides) → [B,T',C_out], as one matrix product."""
    w, b, k, s, p = packed
    n, t, c = x.shape
    if k == 1 and s == 1 and p == 0:
        return torch.addmm(b, x.reshape(n * t, c), w).view(n, t, -1)
    cols = F.pad(x, (0, 0, p, p)).unfold(1, k, s).transpose(2, 3)  # [B, T', k, C], a view
    t_out = cols.shape[1]
    return torch.addmm(b, cols.reshape(n * t_out, k * c), w).view(n, t_out, -1)


def _pack_conv_transpose(conv: nn.ConvTranspose1d) -> tuple:
    """(weight [C_in, k·C_out] with column kk·C_out + o, bias, kernel, stride, padding)."""
    w = conv.weight.detach()  # [C_in, C_out, k]
    k, s = w.shape[2], conv.stride[0]
    if k % s or conv.output_padding[0] or conv.dilation[0] != 1 or conv.groups != 1:
        raise ValueError(f"forward_packed supports ConvTranspose1d with kernel a multiple of stride only, not {conv}")
    packed = w.permute(0, 2, 1).reshape(w.shape[0], k * w.shape[1]).contiguous()
    return packed, _bias(conv, w.shape[1]), k, s, conv.padding[0]


def _conv_transpose_rows(x: torch.Tensor, packed: tuple) -> torch.Tensor:
    """ConvTranspose1d on rows x [B,T,C]: one product gives every input position's k output
    taps; tap kk = j·s + r of position i lands on output s·(i+j) + r (overlap-add, then crop)."""
    w, b, k, s, p = packed
    n, t, c = x.shape
    m = k // s
    z = torch.mm(x.reshape(n * t, c), w).view(n, t, m, s, -1)
    full = sum(F.pad(z[:, :, j], (0, 0, 0, 0, j, m - 1 - j)) for j in range(m))  # [B, T+m-1, s, O]
    t_out = (t - 1) * s - 2 * p + k
    return full.reshape(n, (t + m - 1) * s, -1)[:, p:p + t_out] + b


def _pack_norm(gn: nn.GroupNorm) -> tuple:
    return gn.num_groups, *(None if p is None else p.detach() for p in (gn.weight, gn.bias)), gn.eps


def _norm_act(y: torch.Tensor, norm: tuple) -> torch.Tensor:
    """GroupNorm → Mish of rows y [B,T,C], as rows: GroupNorm reads them as a channels-last [B,C,T,1]
    view, so nothing is transposed or copied (a channel-first copy and back took 0.3-0.4 ms of a
    3.5 ms NoMaD full step on one CPU thread)."""
    n, t, c = y.shape
    z = torch.group_norm(y.view(n, t, 1, c).permute(0, 3, 1, 2), *norm)  # without F.group_norm's checks: ~2 µs a call
    return F.mish(z, inplace=True).permute(0, 2, 3, 1).view(n, t, c)


class ConditionalUnet1D(nn.Module):
    """ε-predictor ``forward(sample [B,T,input_dim], timestep [B] or int, global_cond [B,G])``."""

    def __init__(self, input_dim: int, global_cond_dim: int, diffusion_step_embed_dim: int = 256,
                 down_dims: Sequence[int] = (64, 128, 256), kernel_size: int = 3, n_groups: int = 8):
        super().__init__()
        dsed = diffusion_step_embed_dim
        self.diffusion_step_encoder = nn.Sequential(
            SinusoidalPosEmb(dsed), nn.Linear(dsed, dsed * 4), nn.Mish(), nn.Linear(dsed * 4, dsed))
        cond_dim = dsed + global_cond_dim
        dims = [input_dim, *down_dims]
        in_out = list(zip(dims[:-1], dims[1:]))

        def block(a: int, b: int) -> ConditionalResidualBlock1D:
            return ConditionalResidualBlock1D(a, b, cond_dim, kernel_size, n_groups)

        self.down_modules = nn.ModuleList()
        for i, (a, b) in enumerate(in_out):
            last = i == len(in_out) - 1
            down = nn.Identity() if last else nn.Conv1d(b, b, 3, 2, 1)
            self.down_modules.append(nn.ModuleList([block(a, b), block(b, b), down]))
        mid = dims[-1]
        self.mid_modules = nn.ModuleList([block(mid, mid), block(mid, mid)])
        self.up_modules = nn.ModuleList()
        for a, b in reversed(in_out[1:]):
            self.up_modules.append(nn.ModuleList([block(b * 2, a), block(a, a), nn.ConvTranspose1d(a, a, 4, 2, 1)]))
        start = down_dims[0]
        self.final_conv = nn.Sequential(Conv1dBlock(start, start, kernel_size, n_groups), nn.Conv1d(start, input_dim, 1))

    def _blocks(self) -> list[ConditionalResidualBlock1D]:
        out = [b for res1, res2, _ in self.down_modules for b in (res1, res2)] + list(self.mid_modules)
        return out + [b for res1, res2, _ in self.up_modules for b in (res1, res2)]

    def film_biases(self, timestep: torch.Tensor | int, global_cond: torch.Tensor) -> list[torch.Tensor]:
        """Every block's FiLM bias [N, C, 1] for timesteps [N] (or one) and conditions [N or 1, G].
        They do not depend on the sample, so a sampling loop computes them once for all steps."""
        t = torch.as_tensor(timestep, device=global_cond.device).reshape(-1)
        n = max(len(t), global_cond.shape[0])
        cond = torch.cat([self.diffusion_step_encoder(t).expand(n, -1), global_cond.expand(n, -1)], dim=-1)
        return [blk.cond_encoder(cond)[:, :, None] for blk in self._blocks()]

    def forward(self, sample: torch.Tensor, timestep: torch.Tensor | int | None = None,
                global_cond: torch.Tensor | None = None, biases: list[torch.Tensor] | None = None) -> torch.Tensor:
        """ε for ``sample`` [B,T,input_dim] at ``timestep`` [B] or scalar given ``global_cond``
        [B or 1, G]; or with ``biases`` precomputed by :meth:`film_biases` (batch B or 1)."""
        if biases is None:
            biases = self.film_biases(timestep, global_cond)
        it = iter(biases)
        x = sample.transpose(1, 2)  # [B, input_dim, T]
        skips = []
        for res1, res2, down in self.down_modules:
            x = res2(res1(x, next(it)), next(it))
            skips.append(x)
            x = down(x)
        for m in self.mid_modules:
            x = m(x, next(it))
        for res1, res2, up in self.up_modules:
            x = torch.cat([x, skips.pop()], dim=1)
            x = up(res2(res1(x, next(it)), next(it)))
        return self.final_conv(x).transpose(1, 2)

    def packed_weights(self) -> dict:
        """Repacked weights for :meth:`forward_packed` in execution order, cached and rebuilt when
        any parameter or buffer is replaced or changed in place (:func:`~.packing.packed_cache`)."""
        def blk(b: ConditionalResidualBlock1D) -> tuple:
            (c0, g0, _), (c1, g1, _) = b.blocks
            res = None if isinstance(b.residual_conv, nn.Identity) else _pack_conv(b.residual_conv)
            return _pack_conv(c0), _pack_norm(g0), _pack_conv(c1), _pack_norm(g1), res

        def build() -> dict:
            (fc, fg, _), fout = self.final_conv
            film = [b.cond_encoder[1] for b in self._blocks()]  # Linear on [Mish(t_emb), Mish(cond)]
            dsed = self.diffusion_step_encoder[-1].out_features
            w = torch.cat([lin.weight.detach() for lin in film]).t()  # [dsed + G, ΣC]
            b = torch.cat([_bias(lin, lin.out_features) for lin in film])
            return {"film": (w[:dsed].contiguous(), w[dsed:].contiguous(), b, [lin.out_features for lin in film]),
                    "down": [(blk(r1), blk(r2), None if isinstance(d, nn.Identity) else _pack_conv(d))
                             for r1, r2, d in self.down_modules],
                    "mid": [blk(m) for m in self.mid_modules],
                    "up": [(blk(r1), blk(r2), _pack_conv_transpose(u)) for r1, r2, u in self.up_modules],
                    "final": (_pack_conv(fc), _pack_norm(fg), _pack_conv(fout))}

        return packed_cache(self, build)

    def film_timestep_part(self, timesteps: torch.Tensor, packed: dict) -> torch.Tensor:
        """The timestep half of every block's FiLM bias for timesteps [S]: [S, ΣC] (the bias
        included), computed once per timestep list and kept in ``packed``."""
        w_t, _, b, _ = packed["film"]
        key = ("film_t", tuple(timesteps.tolist()))
        part_t = packed.get(key)
        if part_t is None:
            with torch.no_grad():
                temb = self.diffusion_step_encoder(timesteps.to(w_t.device))
                part_t = packed[key] = torch.addmm(b, F.mish(temb), w_t)
        return part_t

    def packed_film_biases(self, timesteps: torch.Tensor | None, global_cond: torch.Tensor,
                           packed: dict, part_t: torch.Tensor | None = None) -> list[list[torch.Tensor]]:
        """:meth:`film_biases` of every timestep [S] with every condition [N, G]: per step, every
        block's [N, C, 1]. The blocks' FiLM layers act on [Mish(t_emb), Mish(cond)], so the
        timestep half (:meth:`film_timestep_part`, or ``part_t`` when given) and the condition half
        are two products, one each for all blocks."""
        _, w_c, _, sizes = packed["film"]
        part_t = self.film_timestep_part(timesteps, packed) if part_t is None else part_t
        total = part_t[:, None] + torch.mm(F.mish(global_cond), w_c)  # [S, N, ΣC]
        chunks = [c.unsqueeze(-1) for c in total.split(sizes, dim=-1)]  # [S, N, C, 1] per block
        return [[c[k] for c in chunks] for k in range(part_t.shape[0])]

    def forward_packed(self, sample: torch.Tensor, biases: list[torch.Tensor],
                       packed: dict | None = None) -> torch.Tensor:
        """``forward(sample, biases=biases)`` for inference (no autograd), each convolution as one
        matrix product over the rows [B·horizon, C]; ``packed``: :meth:`packed_weights`."""
        return unet_packed(self.packed_weights() if packed is None else packed, sample, biases)


def unet_packed(packed: dict, sample: torch.Tensor, biases: list[torch.Tensor]) -> torch.Tensor:
    """:meth:`ConditionalUnet1D.forward_packed` of the weights ``packed`` (:meth:`ConditionalUnet1D.packed_weights`)
    alone, so that a compiled step (rvn_il.models.compiled) reads nothing of the module."""
    it = iter(biases)

    def res_block(x: torch.Tensor, blk: tuple) -> torch.Tensor:
        c0, g0, c1, g1, res = blk
        h = _norm_act(_conv_rows(x, c0), g0).add_(next(it).transpose(1, 2))  # rows [B,T,C]; the bias [B,C,1] as [B,1,C]
        h = _norm_act(_conv_rows(h, c1), g1)
        return h.add_(x if res is None else _conv_rows(x, res))

    x, skips = sample, []
    for blk1, blk2, down in packed["down"]:
        x = res_block(res_block(x, blk1), blk2)
        skips.append(x)
        x = x if down is None else _conv_rows(x, down)
    for blk in packed["mid"]:
        x = res_block(x, blk)
    for blk1, blk2, up in packed["up"]:
        x = res_block(res_block(torch.cat([x, skips.pop()], dim=-1), blk1), blk2)
        x = _conv_transpose_rows(x, up)
    conv, norm, out = packed["final"]
    return _conv_rows(_norm_act(_conv_rows(x, conv), norm), out)
