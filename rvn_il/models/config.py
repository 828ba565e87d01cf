"""Model configuration: the ``conf/model/<name>.yaml`` files and their ``size`` variants.

A model config is a plain dict: the ``model`` node of rvn-train's config composed by Hydra
(`rvn_data.config.load_config`; a model YAML may extend another through its defaults list,
as nomad_neg extends nomad_pointgoal). ``size: full`` uses the file's values; any other size
merges ``sizes[<size>]`` over them (the resolved dict has no ``sizes`` key) (e.g. ``small``:
fewer channels, 64×64 images, for CPU tests and the reduced-size experiment).
``resolve_size`` is applied both when training and when a checkpoint is loaded, so the saved
config is the single source of truth.
"""
from __future__ import annotations

import copy
from functools import lru_cache
from typing import Any, Mapping

from omegaconf import OmegaConf
from rvn_data.config import load_config

from ..train.settings import register_schema

MODEL_NAMES = ("vint_pointgoal", "nomad_pointgoal", "nomad_neg")


@lru_cache(maxsize=None)
def _composed(name: str) -> dict:
    from hydra.errors import MissingConfigException

    register_schema()
    try:
        cfg = load_config("train", [f"model={name}"])
    except MissingConfigException:
        raise ValueError(f"unknown model {name!r}: no conf/model/{name}.yaml; choose one of "
                         f"{', '.join(MODEL_NAMES)}") from None
    return OmegaConf.to_container(cfg.model, resolve=True)


def load_model_config(name: str, size: str = "full", **overrides: Any) -> dict:
    """The resolved config of model ``name`` at ``size``, then top-level ``overrides``."""
    cfg = copy.deepcopy(_composed(name))
    cfg["size"] = size
    cfg = resolve_size(cfg)
    cfg.update(overrides)
    return cfg


def resolve_size(cfg: Mapping) -> dict:
    """Merge ``sizes[size]`` over the config and drop ``sizes`` (so resolving twice is a no-op)."""
    cfg = dict(cfg)
    if "sizes" not in cfg:
        return cfg
    sizes = cfg.pop("sizes") or {}
    size = cfg.get("size", "full")
    if size == "full":
        return cfg
    if size not in sizes:
        raise ValueError(f"model.size={size!r} is not defined for model {cfg.get('name')!r}; choose full or one of {sorted(sizes)}")
    return OmegaConf.to_container(OmegaConf.merge(cfg, sizes[size]))
