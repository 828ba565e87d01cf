"""NoMaD-PointGoal: NoMaD (reference §4) with the goal-image encoder replaced by a two-layer
MLP on (x_g, y_g). EfficientNet-B0 with GroupNorm → C+1 observation tokens + 1 goal token →
Transformer (goal token hidden as a padded key when ``goal_mask`` = 1) → mean over the visible
tokens = the condition [B, D]. A ConditionalUnet1D predicts the noise of the waypoint deltas,
min-max scaled to [-1, 1] with ``action_stats``; diffusers' DDPMScheduler (10 steps,
squaredcos_cap_v2, clip_sample, epsilon). Distance head 256→64→16→1 on visible goals only.
Loss: alpha·MSE(distance) + (1-alpha)·MSE(ε)."""
from __future__ import annotations

from typing import Mapping

import torch
import torch.nn.functional as F
from torch import nn

from .base import PointGoalModel, masked_mean
from .unet1d import ConditionalUnet1D


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
        from diffusers import DDPMScheduler  # imported here: diffusers takes ~2 s to import
        self.scheduler = DDPMScheduler(num_train_timesteps=self.num_diffusion_iters, beta_schedule="squaredcos_cap_v2",
                                       clip_sample=True, prediction_type="epsilon")
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
        cond = self.condition(self.batch_tokens(batch["obs_image"]), batch["goal_pos"], goal_mask)
        seen = 1.0 - goal_mask
        dist = self.dist_pred_net(cond).squeeze(-1)
        dist_loss = ((dist - batch["distance"].float()) ** 2 * seen).sum() / seen.sum().clamp(min=1.0)
        naction = self.normalize_actions(batch["actions"])
        b = naction.shape[0]
        noise = torch.randn(naction.shape, generator=generator, device=naction.device)
        t = torch.randint(0, self.num_diffusion_iters, (b,), generator=generator, device=naction.device)
        noisy = self.scheduler.add_noise(naction, noise, t)
        pred = self.noise_pred_net(noisy, t, cond)
        diffusion_loss = masked_mean(F.mse_loss(pred, noise, reduction="none").mean(dim=(1, 2)), batch["action_mask"])
        loss = self.alpha * dist_loss + (1 - self.alpha) * diffusion_loss
        return {"loss": loss, "dist_loss": dist_loss, "diffusion_loss": diffusion_loss}

    @torch.no_grad()
    def predict(self, tokens: torch.Tensor, goal: torch.Tensor, num_samples: int = 8,
                generator: torch.Generator | None = None, goal_mask: torch.Tensor | None = None) -> torch.Tensor:
        """Draw ``num_samples`` trajectories per batch item: [B,S,len,2]. The condition is
        computed once and reused by every denoising step; all samples denoise as one batch."""
        b = tokens.shape[0]
        cond = self.condition(tokens, goal, goal_mask)
        if b > 1:
            cond = cond.repeat_interleave(num_samples, dim=0)
        x = torch.randn((b * num_samples, self.len_traj_pred, 2), generator=generator, device=tokens.device)
        self.scheduler.set_timesteps(self.num_diffusion_iters)
        timesteps = self.scheduler.timesteps
        steps = len(timesteps)
        biases = self.noise_pred_net.film_biases(timesteps.to(x.device).repeat_interleave(cond.shape[0]),
                                                 cond.repeat(steps, 1))  # [steps*Bc, C, 1] per block
        bc = cond.shape[0]
        for k, t in enumerate(timesteps):
            eps = self.noise_pred_net(x, biases=[bias[k * bc:(k + 1) * bc] for bias in biases])
            x = self.scheduler.step(eps, int(t), x, generator=generator).prev_sample
        return self.unnormalize_actions(x).view(b, num_samples, self.len_traj_pred, 2)
