"""Point-goal models: ViNT-PointGoal and NoMaD-PointGoal (NoMaD-Neg is two NoMaD-PointGoal)."""
from __future__ import annotations

from typing import Mapping

from .base import PointGoalModel
from .config import MODEL_NAMES, load_model_config, resolve_size
from .nomad import NoMaDPointGoal
from .vint import ViNTPointGoal

ARCHITECTURES = {"vint_pointgoal": ViNTPointGoal, "nomad_pointgoal": NoMaDPointGoal, "nomad_neg": NoMaDPointGoal}


def build_model(cfg: Mapping) -> PointGoalModel:
    """Build the network of a (size-resolved or not) model config; nomad_neg gives one member."""
    cfg = resolve_size(cfg)
    name = cfg.get("name")
    if name not in ARCHITECTURES:
        raise ValueError(f"unknown model {name!r}; choose one of {', '.join(MODEL_NAMES)}")
    return ARCHITECTURES[name](cfg)


__all__ = ["build_model", "load_model_config", "resolve_size", "MODEL_NAMES", "PointGoalModel",
           "ViNTPointGoal", "NoMaDPointGoal"]
