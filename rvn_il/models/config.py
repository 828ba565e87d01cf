"""Model configuration: the ``conf/model/<name>.yaml`` files and their ``size`` variants.

A model config is a plain dict. ``size: full`` uses the file's values; any other size merges
``sizes[<size>]`` over them (the resolved dict has no ``sizes`` key) (e.g. ``small``: fewer channels, 64×64 images, for CPU tests and
the reduced-size experiment). ``resolve_size`` is applied both when training and when a
checkpoint is loaded, so the saved config is the single source of truth.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import rvn_data
import yaml

CONF_DIR = Path(rvn_data.__file__).resolve().parents[1] / "conf"
MODEL_NAMES = ("vint_pointgoal", "nomad_pointgoal", "nomad_neg")


def _read(name: str) -> dict:
    path = CONF_DIR / "model" / f"{name}.yaml"
    if not path.is_file():
        raise ValueError(f"unknown model {name!r}: no {path}; choose one of {', '.join(MODEL_NAMES)}")
    cfg = yaml.safe_load(path.read_text()) or {}
    base: dict = {}
    for entry in cfg.pop("defaults", []) or []:
        if isinstance(entry, str) and entry != "_self_":
            base = _merge(base, _read(entry))
    return _merge(base, cfg)


def _merge(a: Mapping, b: Mapping) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), Mapping) else v
    return out


def load_model_config(name: str, size: str = "full", **overrides: Any) -> dict:
    """The resolved config of model ``name`` at ``size``, then top-level ``overrides``."""
    cfg = _read(name)
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
    return _merge(cfg, sizes[size])
