"""Navigation mesh: walkable surfaces of a scene with Habitat/Recast semantics
(cell size and height, agent radius and height, max climb and slope, small islands dropped).

`NavMesh.build(scene, NavMeshSettings())`, then point queries, sampling, geodesics; each
layer's arrays (`NavGrid`: navigable, floor height, clearance, islands, world↔grid) are in
`NavMesh.layers`, and `NavMesh.grid(island)` is the main one for planners and maps.

The names load on first use, so that the settings (`rvn_data.navmesh.settings`, which every config schema
imports) come without numba and scipy: rvn-train, which builds no navmesh, started 0.4 s slower for them.
"""
from __future__ import annotations

import importlib

_MODULES = {"GeodesicField": "geodesic", "NavGrid": "grid", "NavMesh": "navmesh", "NavMeshSettings": "settings"}
__all__ = list(_MODULES)


def __getattr__(name: str):
    if name in _MODULES:
        return getattr(importlib.import_module(f"rvn_data.navmesh.{_MODULES[name]}"), name)
    raise AttributeError(f"module 'rvn_data.navmesh' has no attribute {name!r}")
