"""Common trunk of the point-goal models: observation tokens from EfficientNet-B0, a goal token
from a two-layer MLP, sinusoidal positions and a pre-norm Transformer.

Contract used by training and policies:
- ``encode_frames(images [N,3,H,W]) -> [N, D]`` (per frame, so a policy caches it): float in [0, 1],
  or uint8 0-255 as the data loader gives them (scaled here, on the model's device); a policy passes
  ``fast=True`` for the encoder's inference form;
- ``forward(batch, generator=None) -> dict`` of scalar losses (``loss`` is optimised);
- ``predict(tokens [B,C+1,D], goal [B,2], num_samples, generator) -> [B,S,len_traj_pred,2]``
  waypoints in units of metric_waypoint_spacing, robot frame (x forward, y left).

Auxiliary depth loss (``depth_aux_weight`` > 0; off by default, a departure from the paper,
whose models see RGB only): a head ``depth_head`` (D → D → S·S, ReLU between) on the current
frame's observation token predicts log depth on an S×S grid; its loss, the mean absolute error
to log(clamp(depth, DEPTH_RANGE)) over the cells where something was hit, is added to ``loss``
with that weight and reported as ``depth_loss`` when the batch has ``depth``. It only shapes
the image encoder during training (policies call the head only for ``policy.depth_veto``), and without the weight the
model has no head, so its checkpoints are those of before. With ``data.depth_root`` the batch
also carries single frames that train the head alone (:mod:`rvn_il.data.depth_frames`).
"""
from __future__ import annotations

from typing import Mapping

import torch
from torch import nn

from .encoders import GoalMLP, ObsEncoder, PositionalEncoding, make_transformer

DEPTH_RANGE = (0.05, 50.0)  # m: log-depth targets are clamped to it (the camera's default far plane)


class PointGoalModel(nn.Module):
    name = "base"
    frame_encoder = None  # encode_frames' compiled encoder (policy.compile: rvn_il.models.compiled); None: obs_encoder
    fast_encoding = True  # encode_frames(fast=True), a policy's: the encoder's inference form; False: its forward

    def __init__(self, cfg: Mapping, group_norm: bool):
        super().__init__()
        self.cfg = dict(cfg)
        self.context_size = int(cfg["context_size"])
        self.len_traj_pred = int(cfg["len_traj_pred"])
        self.image_size = tuple(int(v) for v in cfg["image_size"])  # (W, H)
        d = int(cfg["encoding_size"])
        self.encoding_size = d
        self.obs_encoder = ObsEncoder(d, self.image_size, cfg.get("width_coefficient", 1.0),
                                      cfg.get("depth_coefficient", 1.0), group_norm, cfg.get("imagenet_weights"))
        self.goal_encoder = GoalMLP(d)
        self.positional_encoding = PositionalEncoding(d, self.context_size + 2)
        self.transformer = make_transformer(d, int(cfg["num_heads"]), int(cfg["num_layers"]),
                                            int(cfg["ff_dim_factor"]), float(cfg["dropout"]))
        self.depth_aux_weight = float(cfg.get("depth_aux_weight") or 0.0)
        self.depth_size = int(cfg.get("depth_size", 16))
        self.depth_head = None
        if self.depth_aux_weight > 0:  # drawn from a fork of the RNG: the other weights start as without it
            with torch.random.fork_rng(devices=[]):
                self.depth_head = nn.Sequential(nn.Linear(d, d), nn.ReLU(), nn.Linear(d, self.depth_size ** 2))

    def use_channels_last(self) -> "PointGoalModel":
        """NHWC weights for the image encoder (rvn-train does this): EfficientNet's depthwise
        convolutions train 10-30 % faster on batches (benchmarks/train.py); policies keep NCHW,
        faster for one frame at a time. Values and checkpoints do not change (saved contiguous)."""
        self.obs_encoder.to(memory_format=torch.channels_last)
        return self

    def encode_frames(self, images: torch.Tensor, fast: bool = False) -> torch.Tensor:
        """Tokens [N, D] of images [N,3,H,W]: the compiled encoder where one is set (policy.compile); else with
        ``fast`` (a policy's decisions, without autograd) and ``fast_encoding`` the encoder's inference form
        (:meth:`ObsEncoder.forward_packed`), which agrees with its forward to float rounding."""
        if images.dtype == torch.uint8:  # the loader's frames: the same floats as scaling before the copy
            images = images.float().div_(255.0)
        if self.frame_encoder is not None:
            return self.frame_encoder(images)
        if fast and self.fast_encoding:
            return self.obs_encoder.forward_packed(images)
        return self.obs_encoder(images)

    def batch_tokens(self, obs_image: torch.Tensor) -> torch.Tensor:
        """obs_image [B,C+1,3,H,W] → tokens [B,C+1,D] (all frames through the encoder at once)."""
        b, n = obs_image.shape[:2]
        if n != self.context_size + 1:
            raise ValueError(f"{self.name}: obs_image has {n} frames, expected context_size+1 = {self.context_size + 1}")
        return self.encode_frames(obs_image.flatten(0, 1)).view(b, n, -1)

    def sequence(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None = None) -> torch.Tensor:
        """Transformer over [obs tokens..., goal token] → [B, C+2, D]; masked goals are hidden keys."""
        x = torch.cat([tokens, self.goal_encoder(goal).unsqueeze(1)], dim=1)
        x = self.positional_encoding(x)
        kpm = None
        if goal_mask is not None:
            kpm = torch.zeros(x.shape[:2], dtype=torch.bool, device=x.device)
            kpm[:, -1] = goal_mask > 0.5
        return self.transformer(x, src_key_padding_mask=kpm)

    def with_depth_loss(self, tokens: torch.Tensor, batch: Mapping[str, torch.Tensor],
                        losses: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """``losses`` plus ``depth_loss`` (added to ``loss`` times ``depth_aux_weight``) when the
        model has the depth head and the batch a ``depth`` [B,S,S]; ``tokens`` [B,C+1,D]. A batch
        with ``depth_image`` [F,3,H,W] and ``depth_target`` [F,S,S] (``data.depth_root``,
        :mod:`rvn_il.data.depth_frames`) adds their loss too, with the same weight, as ``depth_extra_loss``."""
        if self.depth_head is None:
            return losses
        out = dict(losses)
        if "depth" in batch:
            out["depth_loss"] = self.depth_error(tokens[:, -1], batch["depth"])
            out["loss"] = out["loss"] + self.depth_aux_weight * out["depth_loss"]
        if "depth_image" in batch:
            out["depth_extra_loss"] = self.depth_error(self.encode_frames(batch["depth_image"]), batch["depth_target"])
            out["loss"] = out["loss"] + self.depth_aux_weight * out["depth_extra_loss"]
        return out

    def depth_error(self, token: torch.Tensor, depth: torch.Tensor) -> torch.Tensor:
        """Mean absolute log-depth error of the head on tokens [B,D] against depth [B,S,S] (metres),
        over the cells where something was hit."""
        depth = depth.float()
        pred = self.depth_head(token).float().view(depth.shape)
        hit = (depth > 0).float()
        error = (pred - depth.clamp(*DEPTH_RANGE).log()).abs()
        return (error * hit).sum() / hit.sum().clamp(min=1.0)


def masked_mean(loss: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """visualnav-transformer's reduction: per-sample loss [B] → mean(loss·mask)/(mean(mask)+1e-2)."""
    return (loss * mask).mean() / (mask.mean() + 1e-2)
