"""NoMaD's reverse process as plain numbers: every step of diffusers' DDPMScheduler
(:func:`ddpm_plan`) or of its η = 0 DDIMScheduler (:func:`ddim_plan`) over the model's inference
timesteps, with its coefficients computed once from the model's :class:`NoiseSchedule`, so that the fast sampling path of
:meth:`rvn_il.models.nomad.NoMaDPointGoal.predict` updates x_t with a few tensor operations per step
(and torch.compile can take them into its graph), in the operation order of ``scheduler.step`` so
the floats match it. :func:`draw_noise` draws a decision's noise before its loop, in the order the
reference loop draws it."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import torch

PREDICTION_TYPES = ("epsilon", "sample", "v_prediction")


class NoiseSchedule(NamedTuple):
    """The numbers of NoMaD's DDPMScheduler (squaredcos_cap_v2 betas, clip_sample, fixed_small variance,
    "leading" timesteps) that the plans read, computed as diffusers computes them, without importing
    diffusers: its import brings torch._dynamo in, ~1.9 s of every process that loads a NoMaD policy
    (``benchmarks/policy_start.py``). The reference path and training keep diffusers' schedulers;
    tests/test_il_sampling.py checks the same floats as theirs."""

    num_train_timesteps: int
    prediction_type: str
    clip: float | None = 1.0  # clip_sample_range, or None without clipping

    def alphas_cumprod(self) -> torch.Tensor:
        """ᾱ_t [T], float32: diffusers' ``betas_for_alpha_bar`` (cosine, max_beta 0.999), then the cumulative product."""
        def alpha_bar(t: float) -> float:
            return math.cos((t + 0.008) / 1.008 * math.pi / 2) ** 2
        n = self.num_train_timesteps
        betas = torch.tensor([min(1 - alpha_bar((i + 1) / n) / alpha_bar(i / n), 0.999) for i in range(n)],
                             dtype=torch.float32)
        return torch.cumprod(1.0 - betas, dim=0)

    def timesteps(self, num_steps: int) -> list[int]:
        """The inference timesteps of ``set_timesteps(num_steps)`` with "leading" spacing, last first."""
        if not 1 <= num_steps <= self.num_train_timesteps:
            raise ValueError(f"{num_steps} inference steps for a schedule of {self.num_train_timesteps} timesteps")
        ratio = self.num_train_timesteps // num_steps
        return [int(t) for t in (np.arange(0, num_steps) * ratio).round()[::-1]]


class DDPMStep(NamedTuple):
    """One reverse step of diffusers' DDPMScheduler as plain numbers: the predicted x0 from the
    model output, clipped, then the posterior mean ``c_x0·x0 + c_xt·x_t`` plus ``std`` times
    fresh noise (none on the last step)."""

    t: int
    kind: str  # prediction_type
    sqrt_a: float  # √ᾱ_t
    sqrt_b: float  # √(1-ᾱ_t)
    clip: float | None  # clip_sample_range, or None without clipping
    c_x0: float
    c_xt: float
    std: float  # 0 on the last step

    def update(self, out: torch.Tensor, x: torch.Tensor, generator: torch.Generator | None = None,
               noise: torch.Tensor | None = None) -> torch.Tensor:
        """x_{t-1} from the model output ``out`` and x_t, in the operation order of
        ``DDPMScheduler.step`` (so the floats match it); the step's ``noise`` is drawn from
        ``generator`` as that draws it unless given (:func:`draw_noise` drew it before the loop)."""
        x0 = predicted_x0(self.kind, self.sqrt_a, self.sqrt_b, out, x)
        if self.clip is not None:
            x0 = x0.clamp(-self.clip, self.clip)
        prev = self.c_x0 * x0 + self.c_xt * x
        if self.std:
            if noise is None:
                noise = step_noise(out.shape, generator, out.device, out.dtype)
            prev = prev + self.std * noise
        return prev


def predicted_x0(kind: str, sqrt_a, sqrt_b, out: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """x0 predicted from the model output ``out`` at x_t (unclipped), for the prediction type ``kind``;
    ``sqrt_a`` = √ᾱ_t and ``sqrt_b`` = √(1-ᾱ_t) as Python floats or 0-d tensors."""
    if kind == "epsilon":
        return (x - sqrt_b * out) / sqrt_a
    if kind == "sample":
        return out
    return sqrt_a * x - sqrt_b * out  # v_prediction


def predicted_eps(kind: str, sqrt_a, sqrt_b, out: torch.Tensor, x: torch.Tensor, x0: torch.Tensor) -> torch.Tensor:
    """The noise ε predicted from ``out`` at x_t, given the unclipped ``x0`` (:func:`predicted_x0`)."""
    if kind == "epsilon":
        return out
    if kind == "sample":
        return (x - sqrt_a * x0) / sqrt_b
    return sqrt_a * out + sqrt_b * x  # v_prediction


def plan_coefficients(plan: list) -> torch.Tensor:
    """Every step's numbers as rows [S, 5] float32 for :func:`coefficient_update`: √ᾱ_t, √(1-ᾱ_t), then
    ``c_x0``, ``c_xt``, ``std`` (DDPM) or ``c_x0``, ``c_eps``, 0 (DDIM); exact, as the plans' floats are float32 values."""
    return torch.tensor([[s.sqrt_a, s.sqrt_b, s.c_x0, s.c_eps if isinstance(s, DDIMStep) else s.c_xt, s.std]
                         for s in plan], dtype=torch.float32)


def coefficient_update(step, coeffs: torch.Tensor, out: torch.Tensor, x: torch.Tensor,
                       noise: torch.Tensor) -> torch.Tensor:
    """``step.update(out, x, noise=noise)`` with the step's numbers read from ``coeffs`` (its row of
    :func:`plan_coefficients`), the same operations in the same order, and ``noise`` always added, times the row's
    ``std`` (give zeros where a DDPM step draws none; DDIM ignores it), so that one compiled graph serves every step of
    a plan (rvn_il.models.compiled). ``step`` gives the prediction type, the clipping and the kind of plan only."""
    sqrt_a, sqrt_b, c_x0, c_1, std = coeffs.unbind()
    x0 = predicted_x0(step.kind, sqrt_a, sqrt_b, out, x)
    eps = predicted_eps(step.kind, sqrt_a, sqrt_b, out, x, x0) if isinstance(step, DDIMStep) else None
    if step.clip is not None:
        x0 = x0.clamp(-step.clip, step.clip)
    if eps is not None:
        return c_x0 * x0 + c_1 * eps
    return c_x0 * x0 + c_1 * x + std * noise


def step_noise(shape: tuple, generator: torch.Generator | None, device: torch.device,
               dtype: torch.dtype = torch.float32) -> torch.Tensor:
    """One DDPM step's noise as ``DDPMScheduler.step`` draws it: on the generator's device, then moved."""
    gen_device = generator.device if generator is not None else device
    return torch.randn(shape, generator=generator, device=gen_device, dtype=dtype).to(device)


def draw_noise(plan: list, shape: tuple, generator: torch.Generator | None,
               device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """x_T and the noise of every step of ``plan`` that draws some ([n, *shape]; n = 0 for DDIM), drawn
    from ``generator`` in the order the sampling loop of the reference path draws them, so both paths see
    the same numbers."""
    x = torch.randn(shape, generator=generator, device=device)
    draws = [step_noise(shape, generator, device) for step in plan if step.std]
    return x, torch.stack(draws) if draws else x.new_zeros((0, *shape))


def ddpm_plan(schedule: NoiseSchedule, num_steps: int) -> list[DDPMStep]:
    """The reverse steps of ``schedule``'s DDPMScheduler over ``num_steps`` inference steps, with every
    coefficient computed once, as ``DDPMScheduler.step`` computes it (float32 tensors, then Python floats)."""
    ts = schedule.timesteps(num_steps)
    acp, one = schedule.alphas_cumprod(), torch.tensor(1.0)
    plan = []
    for i, t in enumerate(ts):
        prev_t = ts[i + 1] if i + 1 < len(ts) else -1
        a_t, a_prev = acp[t], acp[prev_t] if prev_t >= 0 else one
        b_t, b_prev = 1 - a_t, 1 - a_prev
        cur_a = a_t / a_prev
        cur_b = 1 - cur_a
        var = torch.clamp(b_prev / b_t * cur_b, min=1e-20)
        plan.append(DDPMStep(t, schedule.prediction_type, float(a_t ** 0.5), float(b_t ** 0.5), schedule.clip,
                             float(a_prev ** 0.5 * cur_b / b_t), float(cur_a ** 0.5 * b_prev / b_t),
                             float(var ** 0.5) if t > 0 else 0.0))
    return plan


class DDIMStep(NamedTuple):
    """One reverse step of diffusers' DDIMScheduler with η = 0 as plain numbers: the predicted x0
    (clipped) and noise from the model output, then ``√ᾱ_prev·x0 + √(1-ᾱ_prev)·ε``; no noise drawn."""

    t: int
    kind: str  # prediction_type
    sqrt_a: float  # √ᾱ_t
    sqrt_b: float  # √(1-ᾱ_t)
    clip: float | None  # clip_sample_range, or None without clipping
    c_x0: float  # √ᾱ_prev
    c_eps: float  # √(1-ᾱ_prev)
    std = 0.0  # no noise drawn (a class attribute, not a field)

    def update(self, out: torch.Tensor, x: torch.Tensor, generator: torch.Generator | None = None,
               noise: torch.Tensor | None = None) -> torch.Tensor:
        """x_{t-1} from the model output ``out`` and x_t, in the operation order of
        ``DDIMScheduler.step`` (ε from the unclipped x0, as its default ``use_clipped_model_output=False``)."""
        x0 = predicted_x0(self.kind, self.sqrt_a, self.sqrt_b, out, x)
        eps = predicted_eps(self.kind, self.sqrt_a, self.sqrt_b, out, x, x0)
        if self.clip is not None:
            x0 = x0.clamp(-self.clip, self.clip)
        return self.c_x0 * x0 + self.c_eps * eps


def ddim_plan(schedule: NoiseSchedule, num_steps: int) -> list[DDIMStep]:
    """The η = 0 DDIM reverse steps over ``num_steps`` inference steps for the betas of ``schedule``, with
    the timesteps and coefficients diffusers' DDIMScheduler uses with the model's DDPMScheduler config
    (ᾱ_prev = 1 after the last step: ``set_alpha_to_one``)."""
    ts = schedule.timesteps(num_steps)
    ratio = schedule.num_train_timesteps // num_steps
    acp, final = schedule.alphas_cumprod(), torch.tensor(1.0)
    plan = []
    for t in ts:
        a_t = acp[t]
        a_prev = acp[t - ratio] if t - ratio >= 0 else final
        plan.append(DDIMStep(t, schedule.prediction_type, float(a_t ** 0.5), float((1 - a_t) ** 0.5), schedule.clip,
                             float(a_prev ** 0.5), float((1 - a_prev) ** 0.5)))
    return plan
