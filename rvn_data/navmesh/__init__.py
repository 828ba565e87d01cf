"""Navigation mesh: walkable surfaces of a scene with Habitat/Recast semantics
(cell size and height, agent radius and height, max climb and slope, small islands dropped).

`NavMesh.build(scene, NavMeshSettings())`, then point queries, sampling, geodesics; each
layer's arrays (`NavGrid`: navigable, floor height, clearance, islands, world↔grid) are in
`NavMesh.layers`, and `NavMesh.grid(island)` is the main one for planners and maps.
"""
from rvn_data.navmesh.geodesic import GeodesicField
from rvn_data.navmesh.grid import NavGrid
from rvn_data.navmesh.navmesh import NavMesh
from rvn_data.navmesh.settings import NavMeshSettings

__all__ = ["GeodesicField", "NavGrid", "NavMesh", "NavMeshSettings"]
