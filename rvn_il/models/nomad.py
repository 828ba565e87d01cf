"""NoMaD-PointGoal: NoMaD (Sridhar et al., visualnav-transformer) with the goal-image encoder replaced by a two-layer
MLP on (x_g, y_g). EfficientNet-B0 with GroupNorm → C+1 observation tokens + 1 goal token →
Transformer (goal token hidden as a padded key when ``goal_mask`` = 1) → mean over the visible
tokens = the condition [B, D]. A ConditionalUnet1D predicts the noise of the waypoint deltas,
min-max scaled to [-1, 1] with ``action_stats``; diffusers' DDPMScheduler (10 steps,
squaredcos_cap_v2, clip_sample). Distance head 256→64→16→1 on visible goals only.
Loss: alpha·MSE(distance) + (1-alpha)·MSE(denoiser target).

``prediction_type`` picks what the denoiser (still called ``noise_pred_net``, as in the
official code) predicts: ``epsilon`` (the noise; the paper's and official NoMaD's choice),
``sample`` (the clean normalised action sequence, "x0") or ``v_prediction`` (the velocity
√ᾱ·ε − √(1−ᾱ)·x0). With 10 steps of this schedule the last steps keep almost no signal
(ᾱ ≈ 2e-5 at t=9), so an ε-loss there teaches nothing about the action, while an x0-loss
still asks which way to go: see docs/results for the measured effect.

``sampler`` picks the reverse process at inference (``policy.sampler``; training is the same for
both): ``ddpm`` (the paper's and official NoMaD's ancestral sampling, fresh noise at every step but
the last) or ``ddim`` (Song et al. 2021, η = 0: deterministic given the initial noise, diffusers'
DDIMScheduler over the same timesteps), so the samples differ only by where they start."""
from __future__ import annotations

from typing import Mapping, NamedTuple

import torch
import torch.nn.functional as F
from torch import nn

from .base import PointGoalModel, masked_mean
from .unet1d import ConditionalUnet1D

PREDICTION_TYPES = ("epsilon", "sample", "v_prediction")
SAMPLERS = ("ddpm", "ddim")


def check_prediction_type(value: object) -> str:
    """``model.prediction_type`` as one of :data:`PREDICTION_TYPES`; a ValueError naming it otherwise."""
    if value not in PREDICTION_TYPES:
        raise ValueError(f"model.prediction_type={value!r}; choose one of {', '.join(PREDICTION_TYPES)}")
    return str(value)


def check_sampler(value: object) -> str:
    """``policy.sampler`` as one of :data:`SAMPLERS`; a ValueError naming it otherwise."""
    if value not in SAMPLERS:
        raise ValueError(f"policy.sampler={value!r}; choose one of {', '.join(SAMPLERS)}")
    return str(value)


class NoMaDPointGoal(PointGoalModel):
    name = "nomad_pointgoal"

    def __init__(self, cfg: Mapping):
        super().__init__(cfg, group_norm=True)
        down_dims = [int(v) for v in cfg["down_dims"]]
        if self.len_traj_pred % 2 ** (len(down_dims) - 1):
            raise ValueError(f"len_traj_pred={self.len_traj_pred} must be divisible by 2**(len(down_dims)-1) = {2 ** (len(down_dims) - 1)}")
        d = self.encoding_size
        self.noise_pred_net = ConditionalUnet1D(2, d, int(cfg["diffusion_step_embed_dim"]), down_dims,
                                                int(cfg.get("kernel_size", 3)), int(cfg.get("n_groups", 8)))
        self.dist_pred_net = nn.Sequential(nn.Linear(d, d // 4), nn.ReLU(), nn.Linear(d // 4, d // 16), nn.ReLU(), nn.Linear(d // 16, 1))
        self.num_diffusion_iters = int(cfg["num_diffusion_iters"])
        self.prediction_type = check_prediction_type(cfg.get("prediction_type", "epsilon"))
        from diffusers import DDPMScheduler  # imported here: diffusers is slow to import
        self.scheduler = DDPMScheduler(num_train_timesteps=self.num_diffusion_iters, beta_schedule="squaredcos_cap_v2",
                                       clip_sample=True, prediction_type=self.prediction_type)
        stats = cfg["action_stats"]  # "auto": set from the data by the trainer, saved in the weights
        if stats == "auto":
            stats = {"min": [-1.0, -1.0], "max": [1.0, 1.0]}
        elif not isinstance(stats, Mapping) or not all(a < b for a, b in zip(stats["min"], stats["max"])):
            raise ValueError(f"model.action_stats={stats!r}: give auto or {{min: [dx, dy], max: [dx, dy]}} with min < max")
        self.register_buffer("action_min", torch.tensor(stats["min"], dtype=torch.float32))
        self.register_buffer("action_max", torch.tensor(stats["max"], dtype=torch.float32))
        self.alpha = float(cfg.get("alpha", 1e-4))

    # -- action normalisation ---------------------------------------------------------------
    def normalize_actions(self, waypoints: torch.Tensor) -> torch.Tensor:
        """Waypoints [...,len,2] → deltas scaled to [-1, 1] by action_stats."""
        deltas = torch.diff(waypoints, dim=-2, prepend=torch.zeros_like(waypoints[..., :1, :]))
        return 2 * (deltas - self.action_min) / (self.action_max - self.action_min) - 1

    def unnormalize_actions(self, naction: torch.Tensor) -> torch.Tensor:
        deltas = (naction + 1) / 2 * (self.action_max - self.action_min) + self.action_min
        return deltas.cumsum(dim=-2)

    # -- conditioning -----------------------------------------------------------------------
    def condition(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None = None) -> torch.Tensor:
        """Mean of the Transformer outputs over visible tokens → [B, D]."""
        if goal_mask is None:
            goal_mask = torch.zeros(tokens.shape[0], device=tokens.device)
        out = self.sequence(tokens, goal, goal_mask)
        visible = torch.ones(out.shape[:2], device=out.device)
        visible[:, -1] = 1.0 - (goal_mask > 0.5).float()
        return (out * visible.unsqueeze(-1)).sum(1) / visible.sum(1, keepdim=True)

    def forward(self, batch: Mapping[str, torch.Tensor], generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        goal_mask = batch["goal_mask"]
        tokens = self.batch_tokens(batch["obs_image"])
        cond = self.condition(tokens, batch["goal_pos"], goal_mask)
        seen = 1.0 - goal_mask
        dist = self.dist_pred_net(cond).squeeze(-1)
        dist_loss = ((dist - batch["distance"].float()) ** 2 * seen).sum() / seen.sum().clamp(min=1.0)
        naction = self.normalize_actions(batch["actions"])
        b = naction.shape[0]
        noise = torch.randn(naction.shape, generator=generator, device=naction.device)
        t = torch.randint(0, self.num_diffusion_iters, (b,), generator=generator, device=naction.device)
        noisy = self.scheduler.add_noise(naction, noise, t)
        pred = self.noise_pred_net(noisy, t, cond)
        diffusion_loss = masked_mean(F.mse_loss(pred, self.target(naction, noise, t), reduction="none").mean(dim=(1, 2)),
                                     batch["action_mask"])
        loss = self.alpha * dist_loss + (1 - self.alpha) * diffusion_loss
        return self.with_depth_loss(tokens, batch, {"loss": loss, "dist_loss": dist_loss, "diffusion_loss": diffusion_loss})

    def target(self, naction: torch.Tensor, noise: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """What the denoiser is trained to output for ``prediction_type``."""
        if self.prediction_type == "epsilon":
            return noise
        if self.prediction_type == "sample":
            return naction
        return self.scheduler.get_velocity(naction, noise, t)

    fast_sampling = True  # predict's default path; False: module forward + diffusers' scheduler.step
    denoise_step = None  # the fast path's compiled forward_packed (policy.compile: rvn_il.models.compiled)
    sampler = "ddpm"  # the reverse process of predict (module docstring); set by the policy loader

    @torch.inference_mode()
    def predict(self, tokens: torch.Tensor, goal: torch.Tensor, num_samples: int = 8,
                generator: torch.Generator | None = None, goal_mask: torch.Tensor | None = None,
                fast: bool | None = None) -> torch.Tensor:
        """Draw ``num_samples`` trajectories per batch item: [B,S,len,2]. The condition is
        computed once and reused by every denoising step; all samples denoise as one batch; the
        FiLM biases of every step come from one call before the loop.

        ``fast`` (default ``self.fast_sampling``) runs the denoiser's packed inference form
        (:meth:`ConditionalUnet1D.forward_packed`, with the FiLM biases of all steps from
        :meth:`~ConditionalUnet1D.packed_film_biases`) and the precomputed update of
        :func:`ddpm_plan` or :func:`ddim_plan` (``self.sampler``); ``fast=False`` (the reference
        path) runs the module's ``forward`` and diffusers' ``DDPMScheduler.step`` or
        ``DDIMScheduler.step``. Both draw the same noise from ``generator`` in the same order, so
        for a given seed they give the same trajectories up to float rounding."""
        fast = self.fast_sampling if fast is None else bool(fast)
        plan = self._plan() if fast else None  # None: a scheduler setting it does not reproduce
        b = tokens.shape[0]
        cond = self.condition(tokens, goal, goal_mask)
        if b > 1:
            cond = cond.repeat_interleave(num_samples, dim=0)
        x = torch.randn((b * num_samples, self.len_traj_pred, 2), generator=generator, device=tokens.device)
        net = self.noise_pred_net
        if plan is None:
            scheduler = self._inference_scheduler()
            scheduler.set_timesteps(self.num_diffusion_iters)
            timesteps, bc = scheduler.timesteps, cond.shape[0]
            biases = net.film_biases(timesteps.to(x.device).repeat_interleave(bc),
                                     cond.repeat(len(timesteps), 1))  # [steps*Bc, C, 1] per block
            for k, t in enumerate(timesteps):
                out = net(x, biases=[bias[k * bc:(k + 1) * bc] for bias in biases])
                x = scheduler.step(out, int(t), x, generator=generator).prev_sample
        else:
            packed = net.packed_weights()
            biases = net.packed_film_biases(torch.tensor([s.t for s in plan]), cond, packed)
            denoise = self.denoise_step or net.forward_packed
            for step, step_biases in zip(plan, biases):
                x = step.update(denoise(x, step_biases, packed), x, generator)
        return self.unnormalize_actions(x).view(b, num_samples, self.len_traj_pred, 2)

    def _plan(self) -> list[DDPMStep] | list[DDIMStep] | None:
        """:func:`ddpm_plan` or :func:`ddim_plan` of this model's scheduler for ``self.sampler``,
        computed once (again if any of them changes)."""
        key = (self.scheduler, self.num_diffusion_iters, check_sampler(self.sampler))
        cache = getattr(self, "_plan_cache", None)
        if cache is None or cache[0] != key:
            make = ddpm_plan if self.sampler == "ddpm" else ddim_plan
            cache = self._plan_cache = (key, make(self.scheduler, self.num_diffusion_iters))
        return cache[1]

    def _inference_scheduler(self):
        """The diffusers scheduler of the reference path: the training DDPMScheduler, or a
        DDIMScheduler with its config (same betas, clipping and prediction type)."""
        if check_sampler(self.sampler) == "ddpm":
            return self.scheduler
        from diffusers import DDIMScheduler
        return DDIMScheduler.from_config(self.scheduler.config)


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

    def update(self, out: torch.Tensor, x: torch.Tensor, generator: torch.Generator | None) -> torch.Tensor:
        """x_{t-1} from the model output ``out`` and x_t, in the operation order of
        ``DDPMScheduler.step`` (so the floats match it)."""
        if self.kind == "epsilon":
            x0 = (x - self.sqrt_b * out) / self.sqrt_a
        elif self.kind == "sample":
            x0 = out
        else:  # v_prediction
            x0 = self.sqrt_a * x - self.sqrt_b * out
        if self.clip is not None:
            x0 = x0.clamp(-self.clip, self.clip)
        prev = self.c_x0 * x0 + self.c_xt * x
        if self.std:
            gen_device = generator.device if generator is not None else out.device
            noise = torch.randn(out.shape, generator=generator, device=gen_device, dtype=out.dtype).to(out.device)
            prev = prev + self.std * noise
        return prev


def ddpm_plan(scheduler, num_steps: int) -> list[DDPMStep] | None:
    """The reverse steps of ``scheduler`` (a diffusers DDPMScheduler) over ``num_steps`` inference
    steps, with every coefficient computed once, as ``DDPMScheduler.step`` computes it (float32
    tensors, then Python floats). None when the scheduler uses a feature this update does not
    reproduce (thresholding, a variance type other than fixed_small): predict then calls
    ``scheduler.step``."""
    cfg = scheduler.config
    if cfg.thresholding or cfg.variance_type != "fixed_small" or cfg.prediction_type not in PREDICTION_TYPES:
        return None
    scheduler.set_timesteps(num_steps)
    ts = [int(t) for t in scheduler.timesteps]
    acp, one = scheduler.alphas_cumprod.cpu(), scheduler.one.cpu()
    plan = []
    for i, t in enumerate(ts):
        prev_t = ts[i + 1] if i + 1 < len(ts) else -1
        a_t, a_prev = acp[t], acp[prev_t] if prev_t >= 0 else one
        b_t, b_prev = 1 - a_t, 1 - a_prev
        cur_a = a_t / a_prev
        cur_b = 1 - cur_a
        var = torch.clamp(b_prev / b_t * cur_b, min=1e-20)
        plan.append(DDPMStep(t, cfg.prediction_type, float(a_t ** 0.5), float(b_t ** 0.5),
                             float(cfg.clip_sample_range) if cfg.clip_sample else None,
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

    def update(self, out: torch.Tensor, x: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
        """x_{t-1} from the model output ``out`` and x_t, in the operation order of
        ``DDIMScheduler.step`` (ε from the unclipped x0, as its default ``use_clipped_model_output=False``)."""
        if self.kind == "epsilon":
            x0, eps = (x - self.sqrt_b * out) / self.sqrt_a, out
        elif self.kind == "sample":
            x0 = out
            eps = (x - self.sqrt_a * x0) / self.sqrt_b
        else:  # v_prediction
            x0 = self.sqrt_a * x - self.sqrt_b * out
            eps = self.sqrt_a * out + self.sqrt_b * x
        if self.clip is not None:
            x0 = x0.clamp(-self.clip, self.clip)
        return self.c_x0 * x0 + self.c_eps * eps


def ddim_plan(scheduler, num_steps: int) -> list[DDIMStep] | None:
    """The η = 0 DDIM reverse steps over ``num_steps`` inference steps for the betas of
    ``scheduler`` (the model's DDPMScheduler), with the timesteps and coefficients diffusers'
    DDIMScheduler uses (ᾱ_prev = 1 after the last step); None where the config has thresholding."""
    from diffusers import DDIMScheduler
    ddim = DDIMScheduler.from_config(scheduler.config)
    cfg = ddim.config
    if cfg.thresholding or cfg.prediction_type not in PREDICTION_TYPES:
        return None
    ddim.set_timesteps(num_steps)
    ratio = cfg.num_train_timesteps // ddim.num_inference_steps
    plan = []
    for t in (int(t) for t in ddim.timesteps):
        a_t = ddim.alphas_cumprod[t]
        a_prev = ddim.alphas_cumprod[t - ratio] if t - ratio >= 0 else ddim.final_alpha_cumprod
        plan.append(DDIMStep(t, cfg.prediction_type, float(a_t ** 0.5), float((1 - a_t) ** 0.5),
                             float(cfg.clip_sample_range) if cfg.clip_sample else None,
                             float(a_prev ** 0.5), float((1 - a_prev) ** 0.5)))
    return plan
