"""Where a scene's navmesh comes from (`navmesh.source`): built from the scene's triangles,
or read from a Habitat/Recast `.navmesh` file (`navmesh.file`, or for `auto` the one
HM3D ships beside the scene mesh: `<id>.basis.navmesh` / `<id>.navmesh`).

A file's navmesh is in Habitat's frame, which is the scene's frame when the scene is loaded
with `up_axis=z` (HM3D), unit scale 1 and no levelling; a file whose polygons do not lie
within the scene's bounds is refused with an error naming it.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from rvn_data.navmesh.settings import NavMeshSettings

BOUNDS_SLACK = 0.5  # m, how far a file's polygons may reach beyond the scene's bounds


def navmesh_beside(scene_source: str) -> Path | None:
    """The `.navmesh` shipped beside a scene mesh file, or None."""
    if not scene_source:
        return None
    mesh = Path(scene_source)
    if not mesh.is_file():
        return None
    stem = mesh.name.split(".")[0]
    for cand in (mesh.with_suffix(".navmesh"), mesh.parent / f"{stem}.basis.navmesh", mesh.parent / f"{stem}.navmesh"):
        if cand.is_file():
            return cand
    return None


def navmesh_path(scene, settings: NavMeshSettings) -> Path | None:
    """The file the navmesh is read from under these settings, or None when it is built. A scene levelled on load
    (scenes.level) is built under ``auto`` and refused under ``file``: a .navmesh lies in the file's frame (its bounds
    check let a tilt of a few degrees through, the floor then beside the scene's)."""
    if settings.source == "build":
        return None
    if getattr(scene, "levelled", False):
        if settings.source == "file":
            raise ValueError(f"navmesh.source=file: scenes.level=true rotated scene {scene.scene_id!r} to level its "
                             "floor, and a .navmesh file does not follow the rotation; use navmesh.source=build")
        return None
    if settings.file:
        path = Path(settings.file).expanduser()
        if not path.is_file():
            raise ValueError(f"navmesh.file={settings.file!r} not found; give the path of a .navmesh "
                             "or use navmesh.source=build")
        return path
    beside = navmesh_beside(getattr(scene, "source", ""))
    if beside is None and settings.source == "file":
        raise ValueError(f"navmesh.source=file but no navmesh.file is set and there is no .navmesh beside "
                         f"scene {scene.scene_id!r}")
    return beside


def load_navmesh_file(path: str | Path, settings: NavMeshSettings, scene=None):
    """NavMesh from a `.navmesh` file; with `scene`, checked to lie within its bounds."""
    from rvn_data.navmesh.detour_format import read_navmesh_file
    from rvn_data.navmesh.from_detour import navmesh_from_detour

    mesh = read_navmesh_file(path)
    if not any(len(t.polys) and len(t.verts) for t in mesh.tiles):
        raise ValueError(f"navmesh file {str(path)!r} holds no polygon")
    baked = float(mesh.tiles[0].header["walkableRadius"])  # Recast rounds it up to whole cells
    if abs(baked - settings.agent_radius) > max(0.01, float(mesh.settings.get("cellSize", settings.cell_size))):
        warnings.warn(f"navmesh file {str(path)!r} was baked for an agent radius of {baked:.3f} m, the "
                      f"settings say {settings.agent_radius} m; its polygons keep the file's radius", stacklevel=2)
    if scene is not None:
        lo, hi = np.asarray(scene.bounds, dtype=np.float64)
        verts = np.concatenate([t.verts for t in mesh.tiles if len(t.verts)]).astype(np.float64)
        vlo, vhi = verts.min(0), verts.max(0)
        if (vlo < lo - BOUNDS_SLACK).any() or (vhi > hi + BOUNDS_SLACK).any():
            raise ValueError(
                f"navmesh file {str(path)!r} (bounds {np.round(vlo, 2).tolist()}..{np.round(vhi, 2).tolist()}) does not "
                f"lie within scene {scene.scene_id!r} ({np.round(lo, 2).tolist()}..{np.round(hi, 2).tolist()}); "
                "check scenes.up_axis (HM3D: z), unit_scale and level, or use navmesh.source=build")
    scene_id = scene.scene_id if scene is not None else Path(path).name.split(".")[0]
    return navmesh_from_detour(mesh, settings, scene_id)


def open_navmesh(scene, settings: NavMeshSettings | None = None, cache_dir: str | Path | None = None):
    """The scene's `NavMesh` per `settings.source`: read from a file, or `NavMesh.build`; with a cache root
    ``cache_dir``, a build is kept in and read from its ``navmesh/`` folder (`rvn_data.navmesh.disk_cache`)."""
    from rvn_data.navmesh.navmesh import NavMesh

    settings = settings or NavMeshSettings()
    path = navmesh_path(scene, settings)
    if path is None:
        if cache_dir is not None:
            from rvn_data.navmesh.disk_cache import cached_build
            return cached_build(scene, settings, Path(cache_dir).expanduser() / "navmesh")
        return NavMesh.build(scene, settings)
    return load_navmesh_file(path, settings, scene)


def open_scene(spec: str, scenes: dict, settings: NavMeshSettings, cache_dir: str | Path | None = None):
    """(Scene, NavMesh) of a scene spec loaded with the ``scenes`` group's options (``up_axis``,
    ``unit_scale``, ``level``), the navmesh per `open_navmesh` (``cache_dir``: its cache root); raises
    SceneError naming the scene on failure."""
    from rvn_data.scenes.loader import load_scene

    scene = load_scene(spec, up_axis=scenes.get("up_axis", "y"), unit_scale=float(scenes.get("unit_scale", 1.0)),
                       level=bool(scenes.get("level", False)))
    return scene, open_navmesh(scene, settings, cache_dir)
