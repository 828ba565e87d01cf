"""Validation during rvn-train: a held-out loss and open-loop agreement, so under-fitting shows
without a closed-loop run.

``data.val_root`` names an expert GNM dataset written by ``rvn-gen`` on other scenes (for
example ``rvn-gen split=val``). Every ``train.val_every`` steps and at the last step, rank 0
scores the weights a policy would load (the EMA weights when the model keeps them):

- ``val/loss`` (and each loss term): the training loss on a fixed set of held-out samples with
  fixed diffusion noise and timesteps, dropout off, so successive values differ only by the
  weights (without the auxiliary depth term, so it compares with runs trained without it);
- ``val/agreement``: the share of expert frames on which the policy (the checkpoint's own
  waypoint → action settings, sample 0) picks the expert's action, replaying
  ``train.val_trajectories`` expert trajectories exactly as ``python -m rvn_il.eval.agreement``
  does, beside ``val/agreement_blind`` (the blind goal follower on the same frames) and
  ``val/agreement_image``, the policy's agreement on the frames where the blind rule is wrong
  (only the image tells the expert's action there), and ``val/agreement_start`` on each
  trajectory's first ``context_size`` decisions (context padded with the first frame).

The figures go to TensorBoard (``out_dir/tb/<member>``), to the log, and to
``out_dir/<member>/val.json`` (step → figures; rewritten whole, so a resumed run leaves no
duplicate entries).
"""
from __future__ import annotations

import copy
import json
import logging
from pathlib import Path
from typing import Mapping

import numpy as np
import torch

from rvn_data.atomic import write_text_atomic
from rvn_data.conventions import AgentConfig

from ..data import crop_setting, make_dataset
from ..eval.agreement import agreement, expert_trajectories, summary
from ..models import PointGoalModel
from ..policies.control import ControlConfig
from ..policies.policy import Member, PointGoalPolicy

log = logging.getLogger(__name__)


class Validator:
    """Held-out loss and open-loop agreement of one trained member on ``data.val_root``."""

    def __init__(self, root: str | Path, model_cfg: Mapping, data_cfg: Mapping, tcfg: Mapping, agent: Mapping,
                 seed: int, batch_size: int, spacing: float, out_file: Path):
        self.root = Path(root).expanduser()
        if not self.root.is_dir():
            raise ValueError(f"data.val_root={root} does not exist; generate one with rvn-gen split=val "
                             "(expert) or set data.val_root=null")
        split = data_cfg["val_split"] or "all"
        val_data = {**data_cfg, "split": split, "splits_dir": None, "name": None, "skip_short": True}  # own cache key
        self.dataset = make_dataset(self.root, model_cfg, val_data, seed, depth=False)
        self.trajectories = expert_trajectories(self.root, None if split == "all" else split,
                                                int(tcfg["val_trajectories"]))
        n = min(len(self.dataset), int(tcfg["val_batches"]) * batch_size)
        self.batches = np.array_split(np.unique(np.linspace(0, len(self.dataset) - 1, n).astype(np.int64)),
                                      max(1, -(-n // batch_size)))
        pol = dict(model_cfg.get("policy") or {})
        self.control = ControlConfig.from_agent(AgentConfig(**dict(agent or {})), pol.get("stop_radius"),
                                                pol.get("lookahead_min_dist"), pol.get("waypoint_index"))
        self.seed, self.spacing, self.out_file = int(seed), float(spacing), out_file
        self.crop = crop_setting(data_cfg, model_cfg)
        self.history: dict[str, dict] = json.loads(out_file.read_text()) if out_file.is_file() else {}
        log.info("validation on %s: %d samples in %d batches, %d expert trajectories for agreement", self.root,
                 sum(len(b) for b in self.batches), len(self.batches), len(self.trajectories))

    def eval_model(self, model: PointGoalModel, ema_shadow: Mapping[str, torch.Tensor] | None) -> PointGoalModel:
        """A copy of ``model`` in eval mode, holding the EMA weights when there are any, its image
        encoder in the policies' NCHW layout (the same arithmetic as a loaded checkpoint)."""
        copy_ = copy.deepcopy(model)
        if ema_shadow is not None:
            copy_.load_state_dict(ema_shadow)
        copy_.obs_encoder.to(memory_format=torch.contiguous_format)
        return copy_.eval()

    @torch.no_grad()
    def loss(self, model: PointGoalModel) -> dict[str, float]:
        device = next(model.parameters()).device
        gen = torch.Generator(device=device).manual_seed(self.seed)
        totals: dict[str, float] = {}
        for idx in self.batches:
            batch = {k: v.to(device) for k, v in self.dataset.get_batch(idx).items()}
            for k, v in model(batch, gen).items():
                totals[k] = totals.get(k, 0.0) + float(v) * len(idx)
        n = sum(len(b) for b in self.batches)
        return {k: v / n for k, v in totals.items()}

    def agreement(self, model: PointGoalModel) -> dict[str, float]:
        device = next(model.parameters()).device
        policy = PointGoalPolicy([Member(model, self.spacing, self.crop)], self.control, num_samples=1,
                                 seed=self.seed, device=device)
        result = agreement(policy, self.trajectories, model.len_traj_pred, model.context_size)
        policy_figures = summary(result["confusion"])
        return {"agreement": policy_figures["agreement"],
                "agreement_blind": summary(result["blind"])["agreement"],
                "agreement_image": summary(result["needs_image"])["agreement"],
                "agreement_start": summary(result["start"])["agreement"], "steps": policy_figures["steps"]}

    def __call__(self, model: PointGoalModel, ema_shadow: Mapping[str, torch.Tensor] | None, step: int,
                 writer=None) -> dict[str, float]:
        net = self.eval_model(model, ema_shadow)
        figures = {**self.loss(net), **self.agreement(net)}
        if writer is not None:
            for k, v in figures.items():
                if k != "steps":
                    writer.add_scalar(f"val/{k}", v, step)
            writer.flush()
        self.history[str(step)] = {k: round(v, 6) for k, v in figures.items()}
        write_text_atomic(self.out_file, json.dumps(self.history, indent=1, sort_keys=False) + "\n")
        log.info("val @ step %d: loss %.4f, agreement %.3f (blind %.3f; where the image must tell %.3f, %d frames)",
                 step, figures["loss"], figures["agreement"], figures["agreement_blind"], figures["agreement_image"],
                 figures["steps"])
        return figures
