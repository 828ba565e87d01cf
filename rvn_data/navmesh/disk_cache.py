"""Built navmeshes kept on disk (``<cache root>/navmesh``, `rvn_data.cache_root`), so a scene is built once
per cache root instead of at every visit: an RL env over 800 train scenes keeps 3 loaded and switches every 8
resets, so nearly every visit used to rebuild (about 0.1 s a procedural scene, seconds for a large scan);
rvn-eval rows and rvn-gen runs that share a root reuse each other's builds.

A file is ``<scene>-<key>.npz``: the layers' arrays and a JSON record (`FORMAT`). The key hashes everything a
build depends on: the scene's triangles (`Scene.fingerprint`, as the episode files record it), the build settings (the
``source``/``file`` choice aside: only built navmeshes are kept), the code of the navmesh package (not its
docstrings or comments: `rvn_data.code_digest`) and the numpy/scipy versions. Changing any of them makes a new file;
the old one is never read again (the folder is safe to delete). A loaded navmesh equals the built one array for
array, so every output is unchanged.

Writes are atomic (concurrent envs may write the same file: both are whole and equal). A file that cannot be
read is rebuilt and replaced, with a warning; a folder that cannot be written is warned about once and the
navmesh is built without keeping it.
"""
from __future__ import annotations

import hashlib
import io
import json
import re
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path

import numpy as np

from rvn_data.cache_root import cached_file
from rvn_data.code_digest import code_digest as source_digest
from rvn_data.navmesh.grid import NavGrid
from rvn_data.navmesh.settings import SAMPLING, NavMeshSettings

FORMAT = "rvn-navmesh/1"
LAYER_ARRAYS = ("free", "height", "clearance", "island")
LAYER_SCALARS = ("x0", "z0", "cs", "r0", "c0")


@lru_cache(maxsize=1)
def code_digest() -> str:
    """Digest of what builds a navmesh besides its inputs: the navmesh package's code (`rvn_data.code_digest`: its
    docstrings and comments left out), numpy's and scipy's versions."""
    import scipy

    return source_digest(sorted(Path(__file__).parent.glob("*.py")),
                         extra=f"numpy {np.__version__} scipy {scipy.__version__}")


def build_key(scene, settings: NavMeshSettings) -> str:
    """Hash of the scene's triangles (`Scene.fingerprint`), the build settings and `code_digest`."""
    record = {k: v for k, v in asdict(settings).items() if k not in ("source", "file", *SAMPLING)}
    text = json.dumps([FORMAT, code_digest(), record, scene.fingerprint()], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def cache_file(folder: str | Path, scene, key: str) -> Path:
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(scene.scene_id))[-60:].strip("_.") or "scene"
    return Path(folder).expanduser() / f"{slug}-{key}.npz"


def to_bytes(navmesh, key: str) -> bytes:
    """The .npz bytes of a built navmesh: its layers' arrays, seam links and a JSON record of the rest."""
    record = {"format": FORMAT, "key": key, "scene_id": navmesh.scene_id, "island_areas": navmesh.island_areas,
              "scene_grid": [navmesh.x0, navmesh.z0, *navmesh.scene_grid_shape],
              "layers": [{k: getattr(g, k) for k in LAYER_SCALARS} for g in navmesh.layers]}
    arrays = {f"layer{i}_{k}": getattr(g, k) for i, g in enumerate(navmesh.layers) for k in LAYER_ARRAYS}
    buf = io.BytesIO()
    np.savez(buf, record=np.frombuffer(json.dumps(record).encode(), np.uint8), links=navmesh.links, **arrays)
    return buf.getvalue()


def from_file(path: Path, key: str):
    """(layers, island areas, scene grid, links) read from ``path``; ValueError when it is not the file of ``key``."""
    with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
        record = json.loads(z["record"].tobytes())
        if record.get("format") != FORMAT or record.get("key") != key:
            raise ValueError(f"holds {record.get('format')} {record.get('key')}, not {FORMAT} {key}")
        layers = [NavGrid(*(s[k] for k in LAYER_SCALARS), *(z[f"layer{i}_{k}"] for k in LAYER_ARRAYS))
                  for i, s in enumerate(record["layers"])]
        links = z["links"]
    x0, z0, rows, cols = record["scene_grid"]
    return layers, [float(a) for a in record["island_areas"]], (float(x0), float(z0), int(rows), int(cols)), links


def cached_build(scene, settings: NavMeshSettings, folder: str | Path):
    """`NavMesh.build(scene, settings)`, read from ``folder`` when an earlier build left it there, else built
    and written there."""
    from rvn_data.navmesh.navmesh import NavMesh

    key = build_key(scene, settings)
    return cached_file(cache_file(folder, scene, key),
                       lambda path: NavMesh(scene.scene_id, settings, *from_file(path, key)),
                       lambda: NavMesh.build(scene, settings), lambda navmesh: to_bytes(navmesh, key), "navmesh",
                       "built navmeshes", "building each scene every time")
