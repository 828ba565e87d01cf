"""ViNT-PointGoal: ViNT (Shah et al., visualnav-transformer) with the goal-image encoder replaced by a two-layer MLP
on (x_g, y_g). Tokens: C+1 observation tokens + 1 goal token → Transformer → flatten →
MLP (C+2)·D → D → 256-128-64-32 (ReLU after each; the official ``MultiLayerDecoder``) → waypoint deltas (cumsum → waypoints) and an optional
temporal-distance head. Loss: alpha·1e-2·MSE(distance) + (1-alpha)·MSE(waypoints)."""
from __future__ import annotations

from typing import Mapping

import torch
import torch.nn.functional as F
from torch import nn

from .base import PointGoalModel, masked_mean
from .encoders import MLP


class ViNTPointGoal(PointGoalModel):
    name = "vint_pointgoal"

    def __init__(self, cfg: Mapping):
        super().__init__(cfg, group_norm=False)
        d, layers = self.encoding_size, []
        # the official MultiLayerDecoder: the flattened tokens to D first, then decoder_dims
        dims = [(self.context_size + 2) * d, d, *[int(v) for v in cfg.get("decoder_dims", (256, 128, 64, 32))]]
        for a, b in zip(dims[:-1], dims[1:]):
            layers += [nn.Linear(a, b), nn.ReLU()]
        self.decoder = MLP(*layers)
        self.action_head = nn.Linear(dims[-1], self.len_traj_pred * 2)
        self.dist_head = nn.Linear(dims[-1], 1) if cfg.get("distance_head", True) else None
        self.alpha = float(cfg.get("alpha", 0.5))

    def decode(self, tokens: torch.Tensor, goal: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """tokens [B,C+1,D], goal [B,2] → waypoints [B,len,2], distance [B] (or None)."""
        h = self.decoder(self.sequence(tokens, goal).flatten(1))
        waypoints = self.action_head(h).view(-1, self.len_traj_pred, 2).cumsum(dim=1)
        dist = self.dist_head(h).squeeze(-1) if self.dist_head is not None else None
        return waypoints, dist

    def forward(self, batch: Mapping[str, torch.Tensor], generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        tokens = self.batch_tokens(batch["obs_image"])
        waypoints, dist = self.decode(tokens, batch["goal_pos"])
        action_loss = masked_mean(F.mse_loss(waypoints, batch["actions"], reduction="none").mean(dim=(1, 2)),
                                  batch["action_mask"])
        out = {"action_loss": action_loss}
        if dist is not None:
            out["dist_loss"] = F.mse_loss(dist, batch["distance"].float())
            out["loss"] = self.alpha * 1e-2 * out["dist_loss"] + (1 - self.alpha) * action_loss
        else:
            out["loss"] = action_loss
        return self.with_depth_loss(tokens, batch, out)

    @torch.no_grad()
    def predict(self, tokens: torch.Tensor, goal: torch.Tensor, num_samples: int = 1,
                generator: torch.Generator | None = None) -> torch.Tensor:
        """Deterministic: one sample [B,1,len,2] (``num_samples`` is ignored)."""
        return self.decode(tokens, goal)[0].unsqueeze(1)
