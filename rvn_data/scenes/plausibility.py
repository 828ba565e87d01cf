"""Is a mesh file, as read with ``scenes.unit_scale`` and ``scenes.up_axis``, an indoor scene in metres with y up?

Real scans come in other units and axes, and a wrong setting did not fail before: it went on with the wrong scene.

- **Units.** The apartment in ../shared/scenes, saved in millimetres and read as metres, spans 12.4 x 11.3 x 3.1 km.
  rvn-gen was still building its navmesh after 5 minutes. Read in metres as millimetres, it spans 12 mm, and its
  navmesh failed with "no navigable island", which names areas, not units.
- **Up axis.** The same file saved z-up and read y-up stands on its side: its floor becomes a wall and a wall becomes
  the floor. rvn-gen wrote 4 trajectories along a 12 x 2.5 m wall and reported them as ok.

`check_scene` runs in `load_mesh_file` after the file's units and axes are applied, before ``level``. Its
`check_extent` and `check_up_axis` raise a `SceneError` that names the file, what was measured and the setting to
change. A scan not levelled (``scenes.level=false``) whose floor is tilted more than `TILT_NOTE_DEG` is a warning
naming ``scenes.level``: a robot's camera on it would look up or down the slope.

The up-axis test compares two readings of the scene: the one given (y up) and the file turned on its side (its z
axis up). For each reading it measures the largest level floor: the most upward-facing area within one half-metre
band of height. A scene stands on its side when both of these hold:

- the turned reading's floor is larger than the given one's;
- the given reading is 1.5 x taller than it is deep along z (a storey is ~2.7 m tall, a home's plan 6-12 m deep).

Measured on 12 procedural apartments (train 0-11) and the shipped one (tilted 0-10 deg), 2026-12-05:

| reading | turned floor / floor | height / depth |
|---|---:|---:|
| right | 0.40-0.94 | 0.21-0.49 |
| on its side | 1.06-3.07 | 2.05-4.82 |

The floors alone barely separate the procedural apartments (0.94 read right against 1.06 on its side: their walls
line up, so one band holds several), and the heights alone would refuse a tall, narrow scene read right, so a scene
is refused only when both say so. One on its side whose floors do not say so is let through, as before.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from rvn_data.scenes.scene import SceneError

MAX_EXTENT_M = 300.0  # an indoor scene's largest side: a home or an office floor spans tens of metres
MIN_EXTENT_M = 1.0  # ... and its least: a navmesh keeps islands of navmesh.min_island_area (1 m²) and more
UNITS = (("metres", 1.0), ("millimetres", 0.001), ("centimetres", 0.01), ("inches", 0.0254))
ROOM_M, BUILDING_M = 2.0, 100.0  # the units suggested are those that make the largest side a room's to a building's
FLOOR_BAND_M = 0.25  # floors are measured in two neighbouring bands of this height: 0.5 m, for a scan not levelled
LEVEL_COS = math.cos(math.radians(20))  # a face counts as upward facing within 20 deg of up
SIDE_FLOOR_RATIO = 1.0  # the turned reading's floor against the given one's
SIDE_HEIGHT_RATIO = 1.5  # the given reading's height against its depth along z
MIN_FLOOR_M2 = 4.0  # the turned reading's floor must be a room's at least
TILT_NOTE_DEG = 1.5  # a floor tilted more than this, not levelled, is said (the shipped apartment: 0.05 deg)


def check_scene(vertices: np.ndarray, faces: np.ndarray, path, up_axis: str, unit_scale: float, level: bool) -> None:
    """`check_extent`, `check_up_axis`, then the tilt warning where ``level`` is off (see the module's docstring)."""
    by_axis = np.ascontiguousarray(np.asarray(vertices, np.float32).T)  # x, y, z rows: reduced 20x faster than columns
    size = by_axis.max(1) - by_axis.min(1)
    check_extent(size, path, unit_scale)
    geometry = _faces(vertices, faces)
    check_up_axis(size, geometry, path, up_axis)
    if not level:
        _, normals, area2 = geometry
        up = normals[:, 1] > math.cos(math.radians(45)) * area2  # as `mesh_file._level_rotation` finds the floor
        mean = normals[up].sum(0, dtype=np.float64)  # area-weighted: a normal's length is twice its face's area
        tilt = math.degrees(math.acos(min(1.0, mean[1] / np.linalg.norm(mean)))) if up.any() else 0.0
        if tilt > TILT_NOTE_DEG:
            warnings.warn(f"mesh file {str(path)!r}: its floor is tilted {tilt:.1f} deg from level (the area-weighted "
                          "normal of its upward faces); set scenes.level=true to level it (rvn-scene: --level)",
                          stacklevel=3)


def check_extent(size: np.ndarray, path, unit_scale: float) -> None:
    """SceneError when the scene (its ``size`` along x, y, z in metres, after ``unit_scale``) spans more than
    `MAX_EXTENT_M` or less than `MIN_EXTENT_M`, with the sizes it would have in those other `UNITS` that make it a
    room to a building (all of them if none does)."""
    large = size.max() > MAX_EXTENT_M
    if not large and size.max() >= MIN_EXTENT_M:
        return
    if not size.max() > 0:  # no units make a point a room
        raise SceneError(f"mesh file {str(path)!r}: every vertex lies at one point, so its geometry was not read; "
                         "re-export it without compression or quantisation (the reader is trimesh)")
    units = [(name, scale) for name, scale in UNITS if not math.isclose(scale, unit_scale)]
    in_file = size / unit_scale
    fits = [(name, scale) for name, scale in units if ROOM_M <= in_file.max() * scale <= BUILDING_M] or units
    hint = "; ".join(f"as {name} (scenes.unit_scale={scale:g}) {_sides(in_file * scale)}" for name, scale in fits)
    what = (f"larger than an indoor scene (at most {MAX_EXTENT_M:.0f} m)" if large
            else f"smaller than a room (at least {MIN_EXTENT_M:.0f} m)")
    far = "; if it is right, some of its geometry lies far from the rest" if large else ""
    raise SceneError(f"mesh file {str(path)!r} read with scenes.unit_scale={unit_scale:g} spans {_sides(size)}: "
                     f"{what}. If scenes.unit_scale is wrong: {hint} (rvn-scene: --unit-scale){far}")


def check_up_axis(size: np.ndarray, geometry: tuple, path, up_axis: str) -> None:
    """SceneError when the scene (y up as read; its ``size`` along x, y, z, its faces' `_faces`) stands on its side:
    see the module's docstring."""
    corner, normals, area2 = geometry
    floor = largest_floor(normals, area2, corner, 1, 1)
    turned = max(largest_floor(normals, area2, corner, 2, 1), largest_floor(normals, area2, corner, 2, -1))
    if turned >= MIN_FLOOR_M2 and turned > SIDE_FLOOR_RATIO * floor and size[1] > SIDE_HEIGHT_RATIO * size[2]:
        other = "z" if up_axis == "y" else "y"
        raise SceneError(
            f"mesh file {str(path)!r} read with scenes.up_axis={up_axis} stands on its side: it is {size[1]:.1f} m "
            f"tall and {size[2]:.1f} m deep, and its largest level floor faces along its depth ({turned:.0f} m² "
            f"against {floor:.0f} m² facing up). Set scenes.up_axis={other} (rvn-scene: --up-axis {other}); HM3D "
            "and Habitat files are z-up, glTF files y-up")


def largest_floor(normals: np.ndarray, area2: np.ndarray, corners: np.ndarray, axis: int, sign: int) -> float:
    """m² of the faces facing ``sign`` along ``axis`` (within `LEVEL_COS`) in the two neighbouring bands of
    `FLOOR_BAND_M` that hold the most of them (``normals``: unnormalised, their lengths ``area2`` twice the faces'
    areas; ``corners``: a point of each face)."""
    up = sign * normals[:, axis] > LEVEL_COS * area2
    if not up.any():
        return 0.0
    height = sign * corners[up, axis].astype(np.float64)
    band = np.floor((height - height.min()) / FLOOR_BAND_M).astype(np.int64)
    area = np.bincount(band, weights=area2[up] / 2)
    return float((area + np.append(area[1:], 0.0)).max())


def _faces(vertices: np.ndarray, faces: np.ndarray) -> tuple:
    """(a corner of each face, its normal unnormalised, the normal's length: twice the face's area), float32."""
    v = np.asarray(vertices, np.float32)
    corner = v[faces[:, 0]]  # a face's height: one corner's (the bands are 0.25 m; a level face's corners agree)
    normals = np.cross(v[faces[:, 1]] - corner, v[faces[:, 2]] - corner)
    return corner, normals, np.sqrt(np.einsum("ij,ij->i", normals, normals))


def _sides(size: np.ndarray) -> str:
    """``size`` (m) as ``12.4 x 2.8 x 11.3 m`` (sides under a metre to 3 figures: ``0.0124``)."""
    return " x ".join(f"{s:,.1f}" if s >= 1 else f"{s:.3g}" for s in size) + " m"
