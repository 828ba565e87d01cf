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

from typing import Mapping

import torch
import torch.nn.functional as F
from torch import nn

from .base import PointGoalModel, masked_mean
from .sampling_plan import PREDICTION_TYPES, DDIMStep, DDPMStep, NoiseSchedule, ddim_plan, ddpm_plan, draw_noise
from .unet1d import ConditionalUnet1D

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
        # the sampling plans' numbers; diffusers' DDPMScheduler (`scheduler`) is made on first use
        self.noise_schedule = NoiseSchedule(self.num_diffusion_iters, self.prediction_type)
        stats = cfg["action_stats"]  # "auto": set from the data by the trainer, saved in the weights
        if stats == "auto":
            stats = {"min": [-1.0, -1.0], "max": [1.0, 1.0]}
        elif not isinstance(stats, Mapping) or not all(a < b for a, b in zip(stats["min"], stats["max"])):
            raise ValueError(f"model.action_stats={stats!r}: give auto or {{min: [dx, dy], max: [dx, dy]}} with min < max")
        self.register_buffer("action_min", torch.tensor(stats["min"], dtype=torch.float32))
        self.register_buffer("action_max", torch.tensor(stats["max"], dtype=torch.float32))
        self.alpha = float(cfg.get("alpha", 1e-4))

    @property
    def scheduler(self):
        """diffusers' DDPMScheduler of :attr:`noise_schedule` (training's ``add_noise``, the reference path), made on
        first use: importing diffusers takes ~1.9 s, which a policy's fast sampling path does without."""
        if getattr(self, "_scheduler", None) is None:
            from diffusers import DDPMScheduler
            s = self.noise_schedule
            self._scheduler = DDPMScheduler(num_train_timesteps=s.num_train_timesteps, beta_schedule="squaredcos_cap_v2",
                                            clip_sample=s.clip is not None, clip_sample_range=s.clip or 1.0,
                                            prediction_type=s.prediction_type)
        return self._scheduler

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
    sampling_graph = None  # the fast path's compiled sample_packed (policy.compile: rvn_il.models.compiled)
    sampler = "ddpm"  # the reverse process of predict (module docstring); set by the policy loader

    @torch.inference_mode()
    def predict(self, tokens: torch.Tensor, goal: torch.Tensor, num_samples: int = 8,
                generator: torch.Generator | None = None, goal_mask: torch.Tensor | None = None,
                fast: bool | None = None) -> torch.Tensor:
        """Draw ``num_samples`` trajectories per batch item: [B,S,len,2]. The condition is
        computed once and reused by every denoising step; all samples denoise as one batch; the
        FiLM biases of every step come from one call before the loop.

        ``fast`` (default ``self.fast_sampling``) runs :meth:`sample_packed`: the denoiser's packed
        inference form (:meth:`ConditionalUnet1D.forward_packed`) and the precomputed update of
        :func:`ddpm_plan` or :func:`ddim_plan` (``self.sampler``), with every step's noise drawn
        before the loop (:func:`~.sampling_plan.draw_noise`), in the order the loop would draw it; ``fast=False``
        (the reference path) runs the module's ``forward`` and diffusers' ``DDPMScheduler.step`` or
        ``DDIMScheduler.step``, which draw noise as they go. Both draw the same noise from
        ``generator`` in the same order, so for a given seed they give the same trajectories up to
        float rounding."""
        fast = self.fast_sampling if fast is None else bool(fast)
        b = tokens.shape[0]
        shape = (b * num_samples, self.len_traj_pred, 2)
        if fast:
            x, noise = draw_noise(self._plan(), shape, generator, tokens.device)
            x = (self.sampling_graph or self.sample_packed)(tokens, goal, goal_mask, x, noise)
            return self.unnormalize_actions(x).view(b, num_samples, self.len_traj_pred, 2)
        cond = self.condition(tokens, goal, goal_mask)
        if b > 1:
            cond = cond.repeat_interleave(num_samples, dim=0)
        x = torch.randn(shape, generator=generator, device=tokens.device)
        net = self.noise_pred_net
        scheduler = self._inference_scheduler()
        scheduler.set_timesteps(self.num_diffusion_iters)
        timesteps, bc = scheduler.timesteps, cond.shape[0]
        biases = net.film_biases(timesteps.to(x.device).repeat_interleave(bc),
                                 cond.repeat(len(timesteps), 1))  # [steps*Bc, C, 1] per block
        for k, t in enumerate(timesteps):
            out = net(x, biases=[bias[k * bc:(k + 1) * bc] for bias in biases])
            x = scheduler.step(out, int(t), x, generator=generator).prev_sample
        return self.unnormalize_actions(x).view(b, num_samples, self.len_traj_pred, 2)

    def sample_packed(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None,
                      x: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """The fast path of :meth:`predict` from the condition to the last denoising step, all
        samples of a batch item in one batch: x_T [B·S, len, 2] and the steps' noise ``noise``
        [steps that draw, B·S, len, 2] (:func:`~.sampling_plan.draw_noise`) → x_0, normalised. Two parts, each
        free of random draws and Python-side caches so that torch.compile can take it whole
        (rvn_il.models.compiled): :meth:`step_biases`, then :meth:`denoise_packed`."""
        packed = self.noise_pred_net.packed_weights()
        biases = self.step_biases(tokens, goal, goal_mask, x.shape[0], packed, self.plan_film_part(packed))
        return self.denoise_packed(x, noise, biases, packed)

    def plan_film_part(self, packed: dict) -> torch.Tensor:
        """The FiLM timestep part of the sampling plan's steps (:meth:`ConditionalUnet1D.film_timestep_part`)."""
        return self.noise_pred_net.film_timestep_part(torch.tensor([s.t for s in self._plan()]), packed)

    def step_biases(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None, rows: int,
                    packed: dict, part_t: torch.Tensor) -> list[list[torch.Tensor]]:
        """Every denoising step's FiLM biases [rows, C, 1] per block for the condition of ``tokens`` and
        ``goal`` (each batch item's condition repeated for its ``rows // B`` samples)."""
        cond = self.condition(tokens, goal, goal_mask)
        if rows > cond.shape[0] > 1:
            cond = cond.repeat_interleave(rows // cond.shape[0], dim=0)
        return self.noise_pred_net.packed_film_biases(None, cond, packed, part_t)

    def denoise_packed(self, x: torch.Tensor, noise: torch.Tensor, biases: list[list[torch.Tensor]],
                       packed: dict) -> torch.Tensor:
        """Every step of the sampling plan from x_T: the packed U-Net (:meth:`ConditionalUnet1D.forward_packed`)
        with that step's ``biases``, then the step's update with its ``noise`` (in plan order, one per step that draws)."""
        net, k = self.noise_pred_net, 0
        for step, step_biases in zip(self._plan(), biases):
            out = net.forward_packed(x, step_biases, packed)
            x = step.update(out, x, noise=noise[k] if step.std else None)
            k += bool(step.std)
        return x

    def _plan(self) -> list[DDPMStep] | list[DDIMStep]:
        """:func:`ddpm_plan` or :func:`ddim_plan` of this model's noise schedule for ``self.sampler``,
        computed once (again if any of them changes)."""
        key = (self.noise_schedule, self.num_diffusion_iters, check_sampler(self.sampler))
        cache = getattr(self, "_plan_cache", None)
        if cache is None or cache[0] != key:
            make = ddpm_plan if self.sampler == "ddpm" else ddim_plan
            cache = self._plan_cache = (key, make(self.noise_schedule, self.num_diffusion_iters))
        return cache[1]

    def _inference_scheduler(self):
        """The diffusers scheduler of the reference path: the training DDPMScheduler, or a
        DDIMScheduler with its config (same betas, clipping and prediction type)."""
        if check_sampler(self.sampler) == "ddpm":
            return self.scheduler
        from diffusers import DDIMScheduler
        return DDIMScheduler.from_config(self.scheduler.config)
