"""Train-mode goal pools kept on disk (``<cache root>/goal_pools``, `rvn_data.cache_root`), so a scene's pool is
solved once per cache root instead of at every visit of every process. An RL env over 800 train scenes switches
scene every 8 resets and a process keeps ~20 pools, so nearly every visit used to solve its 64 Dijkstra fields again
(0.27-0.36 s a procedural scene on the development CPU); read back instead, 2 workers x 2 envs on 200 scenes
stepped x1.33 faster with `env.prefetch_scenes`, x1.98 without (benchmarks/scene_prefetch.py). The node's env workers
and the nodes of a cluster that share a root solve each scene's pool once between them.

A file is ``<scene>-<key>.npz``: the pool's arrays (`FieldTrees`' pickled state: goals, their graph nodes and
cells, the predecessors, the smoothed float32 values) and a JSON record (`FORMAT`). The predecessors are stored as
each node's offset to its predecessor (0 for none: a node is never its own predecessor) beside the roots' and
unreached nodes' markers, which compress to ~0.3-0.5 MB for 64 goals against 3-4 MB raw; the values as byte planes
(every value's first byte, then every value's second, ...: 28 % smaller compressed than as floats), ~2-3.5 MB for 64
goals on a procedural apartment (3.4-6.3 MB raw), so a cache root holds ~2.5-4 MB a train scene. The key hashes
everything a pool depends on: the navmesh's content (`navmesh_digest`: its layers, links and settings, whether built
or read from a file), the pool's size, split code and scene index (its goals' seed), the code of the navmesh
package, the goal pool and this module (not their docstrings or comments: `rvn_data.code_digest`) and numpy's and
scipy's versions.
Changing any of them makes a new file; the old one is never read again (the folder is safe to delete). A pool read
back equals the built one array for array, so every goal draw and episode is unchanged.

Writes are atomic (envs of several processes may write the same file: both are whole and equal). A file that
cannot be read is rebuilt and replaced, with a warning; a folder that cannot be written is warned about once and
the pool built without keeping it.
"""
from __future__ import annotations

import hashlib
import io
import json
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path

import numpy as np

from rvn_data.cache_root import cached_file
from rvn_data.code_digest import code_digest as source_digest
from rvn_data.navmesh import disk_cache
from rvn_data.navmesh.field_sets import FieldTrees

FORMAT = "rvn-goal-pool/2"  # /2: with the smoothed values


@lru_cache(maxsize=1)
def code_digest() -> str:
    """The navmesh package's digest (`disk_cache.code_digest`) with the code of the goal pool and this module
    (`rvn_data.code_digest`: not their docstrings or comments)."""
    here = Path(__file__).parent
    return source_digest([here / "goal_pool.py", here / "pool_cache.py"], extra=disk_cache.code_digest())


def navmesh_digest(navmesh) -> str:
    """Hash of what a navmesh's geodesic fields and samples depend on: its layers' arrays and scalars, seam links,
    island areas, grid and settings (~0.3 ms for a procedural apartment)."""
    h = hashlib.sha256(json.dumps([asdict(navmesh.settings), navmesh.island_areas, navmesh.x0, navmesh.z0,
                                   list(navmesh.scene_grid_shape)], sort_keys=True, default=str).encode())
    for layer in navmesh.layers:
        h.update(json.dumps([float(getattr(layer, k)) for k in disk_cache.LAYER_SCALARS]).encode())
        for k in disk_cache.LAYER_ARRAYS:
            a = np.ascontiguousarray(getattr(layer, k))
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
    h.update(np.ascontiguousarray(navmesh.links).tobytes())
    return h.hexdigest()


def file_key(navmesh, size: int, split_code: int, scene_index: int) -> str:
    """The key of a pool's file: its navmesh's content, size, split code, scene index and `code_digest`."""
    text = json.dumps([FORMAT, code_digest(), navmesh_digest(navmesh), int(size), int(split_code), int(scene_index)])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def to_bytes(stack: FieldTrees, key: str) -> bytes:
    """The .npz bytes of a pool's fields: their pickled state, the predecessors as offsets, the values as byte planes,
    and a JSON record."""
    state = stack.__getstate__()
    if not state.get("smoothed"):
        raise ValueError("a pool's file holds fields smoothed whole (FieldTrees(..., smooth=True))")
    pred, values = state.pop("pred"), state.pop("values")
    state["value_bytes"] = np.ascontiguousarray(np.moveaxis(values.view(np.uint8).reshape(values.shape + (-1,)), -1, 0))
    node = np.arange(pred.shape[1], dtype=pred.dtype)
    offsets = np.where(pred >= 0, pred - node, 0).astype(pred.dtype)  # never 0 for a predecessor
    arrays = {k: v for k, v in state.items() if isinstance(v, np.ndarray)}
    record = {"format": FORMAT, "key": key, "scalars": {k: v for k, v in state.items() if k not in arrays}}
    buf = io.BytesIO()
    np.savez_compressed(buf, record=np.frombuffer(json.dumps(record).encode(), np.uint8), pred_offsets=offsets,
                        pred_none=np.where(pred < 0, pred, 0).astype(pred.dtype), **arrays)
    return buf.getvalue()


def from_file(path: Path, key: str) -> FieldTrees:
    """The pool's fields read from ``path``; ValueError when it is not the file of ``key``."""
    with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
        record = json.loads(z["record"].tobytes())
        if record.get("format") != FORMAT or record.get("key") != key:
            raise ValueError(f"holds {record.get('format')} {record.get('key')}, not {FORMAT} {key}")
        state = {k: z[k] for k in z.files if k not in ("record", "pred_offsets", "pred_none")}
        offsets, none = z["pred_offsets"], z["pred_none"]
    if offsets.ndim != 2 or offsets.shape != none.shape or offsets.dtype != none.dtype:
        raise ValueError(f"its predecessor arrays disagree: {offsets.dtype}{offsets.shape}, {none.dtype}{none.shape}")
    node = np.arange(offsets.shape[1], dtype=offsets.dtype)
    state["pred"] = np.where(offsets != 0, offsets + node, none).astype(offsets.dtype, copy=False)
    planes = state.pop("value_bytes")
    dtype = np.dtype(record["scalars"]["dtype"])
    if planes.shape != (dtype.itemsize, *offsets.shape) or planes.dtype != np.uint8:
        raise ValueError(f"its values disagree with its predecessors: {planes.dtype}{planes.shape}")
    state["values"] = np.ascontiguousarray(np.moveaxis(planes, 0, -1)).view(dtype)[..., 0]
    stack = FieldTrees.__new__(FieldTrees)
    stack.__setstate__({**state, **record["scalars"]})
    return stack


def cached_stack(navmesh, goals_of, size: int, split_code: int, scene_index: int, folder: str | Path) -> FieldTrees:
    """A goal pool's `FieldTrees`: read from ``folder`` when an earlier build left it there, else
    ``FieldTrees(navmesh, goals_of())`` (its Dijkstra solves) and written there."""
    key = file_key(navmesh, size, split_code, scene_index)
    return cached_file(disk_cache.cache_file(folder, navmesh, key), lambda path: from_file(path, key),
                       lambda: FieldTrees(navmesh, goals_of()), lambda stack: to_bytes(stack, key), "goal pool",
                       "goal pools", "solving each scene's pool at every visit")
