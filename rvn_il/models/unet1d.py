"""Conditional 1-D U-Net noise predictor, as ConditionalUnet1D of real-stanford/diffusion_policy
(the one NoMaD uses): residual Conv1d blocks with GroupNorm and Mish, a bias-only FiLM term
from [sinusoidal timestep embedding → MLP, global condition], stride-2 down/up sampling with
skip connections. Input and output are [B, horizon, input_dim]."""
from __future__ import annotations

import math
from typing import Sequence

import torch
from torch import nn


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
