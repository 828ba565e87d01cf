"""Stable names and seeds: a trajectory is a pure function of (settings, seed, scene, index)."""
from __future__ import annotations

import re
import zlib
from pathlib import Path

import numpy as np

from rvn_data.dataset.settings import KINDS


def scene_slug(spec: str) -> str:
    """Folder-safe short name of a scene spec: ``procedural:train/12`` → ``proc_train_0012``,
    a mesh path → its file stem (sanitised)."""
    m = re.fullmatch(r"procedural:(\w+)/(\d+)", spec)
    if m:
        return f"proc_{m.group(1)}_{int(m.group(2)):04d}"
    stem = Path(spec).stem or spec
    return re.sub(r"[^A-Za-z0-9.-]+", "_", stem).strip("_") or "scene"


def traj_name(slug: str, kind: str, index: int) -> str:
    return f"{slug}_{kind}_{index:04d}"


def attempt_rng(seed: int, kind: str, slug: str, index: int, attempt: int) -> np.random.Generator:
    """The Generator of one attempt: independent of sharding, resume order and scene lists."""
    return np.random.default_rng([seed, KINDS.index(kind), zlib.crc32(slug.encode()), index, attempt])


def check_unique(specs: list[str]) -> dict[str, str]:
    """slug → spec for a scene list; two specs with the same slug are an error."""
    out: dict[str, str] = {}
    for spec in specs:
        slug = scene_slug(spec)
        if slug in out:
            raise ValueError(f"scenes {out[slug]!r} and {spec!r} would share the trajectory prefix {slug!r}; "
                             "rename one of the files")
        out[slug] = spec
    return out
