"""Navigation-mesh settings: Habitat/Recast semantics (cell size and height, agent radius and
height, climb, slope, small islands dropped), and where the navmesh comes from."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Mapping


@dataclass(frozen=True)
class NavMeshSettings:
    """How walkable surfaces are extracted from a scene mesh.

    cell_size: horizontal grid cell (m); cell_height: vertical resolution of surface
    heights (m); agent_radius: erosion radius (m); agent_height: clearance needed above a
    surface (m); max_climb: largest step between neighbouring surfaces (m);
    max_slope_deg: steepest walkable face; min_island_area: connected navigable islands
    smaller than this (m²) are dropped.
    source: where the navmesh comes from: "build" (from the scene's triangles), "file" (a
    Habitat/Recast `.navmesh`: `file`, else the one beside the scene file, an error if
    none) or "auto" (`file` when set, else a `.navmesh` beside the scene file when there is
    one, else build); see `rvn_data.navmesh.source.open_navmesh`. The default is "build" so
    that a run never changes navmesh because a file appeared beside a scene; HM3D users who
    want Habitat's shipped navmeshes say `navmesh.source=auto` (recorded in the run identity).
    profile: how a navmesh is built from triangles (`rvn_data.navmesh.profiles`): "rvn" (exact
    sub-cell clearance: the edge lies `agent_radius` from the obstacle geometry, convex corners
    rounded) or "habitat" (Recast's build semantics as habitat-sim bakes it: cell height 0.2 m,
    radius rounded up to whole cells, climb in cell-height units, cells partly covered count as
    blocked, corners cut square, gaps narrower than the rounded diameter closed).
    islands: where starts and goals are drawn (episodes, trajectories, RL resets, goal pools):
    "main" (the largest island alone) or "all" (Habitat's PointNav rule: the main island and
    every other island whose radius, the largest distance of its cells from their centroid, is
    at least `min_island_radius`; a point is drawn uniformly over their area, so an island's
    share of starts is its share of the area, and goals on the start's island). A multi-storey
    scan's floors are islands of their own; "main" uses one of them. Neither changes the navmesh.
    """

    cell_size: float = 0.05  # m, horizontal grid cell
    cell_height: float = 0.01  # m, vertical resolution of surface heights
    agent_radius: float = 0.18  # m, erosion radius (the configs set it to agent.r_robot)
    agent_height: float = 1.0  # m, clearance needed above a surface (the configs: agent.h_robot)
    max_climb: float = 0.2  # m, largest step between neighbouring surfaces
    max_slope_deg: float = 45.0  # deg, steepest walkable face
    min_island_area: float = 1.0  # m², smaller connected islands are dropped
    source: str = "build"  # build | auto | file: auto uses `file`, else <scene>.navmesh beside the scene file, else builds
    file: str | None = None  # path of a Habitat/Recast .navmesh (source=file, or auto)
    profile: str = "rvn"  # rvn (exact clearance) | habitat (Recast's cell-rounded build)
    islands: str = "main"  # main | all: where starts and goals are drawn (all: + every island of min_island_radius)
    min_island_radius: float = 1.5  # m, islands=all: Habitat's ISLAND_RADIUS_LIMIT (pointnav_generator.py)

    def __post_init__(self) -> None:
        if self.source not in SOURCES:
            raise ValueError(f"navmesh setting source={self.source!r} must be one of {list(SOURCES)}")
        if self.profile not in PROFILES:
            raise ValueError(f"navmesh setting profile={self.profile!r} must be one of {list(PROFILES)}")
        if self.islands not in ISLANDS:
            raise ValueError(f"navmesh setting islands={self.islands!r} must be one of {list(ISLANDS)} "
                             "(main: the largest island; all: every island of radius >= navmesh.min_island_radius)")
        if self.file is not None and not isinstance(self.file, str):
            object.__setattr__(self, "file", str(self.file))
        if self.file is not None and self.source == "build":
            raise ValueError(f"navmesh.file={self.file!r} is set but navmesh.source=build ignores it; "
                             "add navmesh.source=file (or auto)")
        for f in fields(self):
            if f.name in TEXT:
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"navmesh setting {f.name}={value!r} must be a finite number")
            object.__setattr__(self, f.name, float(value))
        for name in ("cell_size", "cell_height", "agent_height"):
            if getattr(self, name) <= 0:
                raise ValueError(f"navmesh setting {name}={getattr(self, name)!r} must be > 0")
        for name in ("agent_radius", "max_climb", "min_island_area", "min_island_radius"):
            if getattr(self, name) < 0:
                raise ValueError(f"navmesh setting {name}={getattr(self, name)!r} must be >= 0")
        if not 0 < self.max_slope_deg < 90:
            raise ValueError(f"navmesh setting max_slope_deg={self.max_slope_deg!r} must be in (0, 90)")
        if self.cell_size > 1.0 or self.cell_height > 1.0:
            raise ValueError(
                f"navmesh settings cell_size={self.cell_size}, cell_height={self.cell_height} "
                "are absurd (metres; expected about 0.05 and 0.01)")
        if self.max_climb >= self.agent_height:
            raise ValueError(
                f"navmesh setting max_climb={self.max_climb} must be smaller than "
                f"agent_height={self.agent_height}")

    @classmethod
    def from_config(cls, cfg: Mapping[str, Any] | None = None, **overrides: Any) -> "NavMeshSettings":
        """Settings from a mapping (e.g. the Hydra `navmesh` group); unknown keys are an error."""
        values = dict(cfg or {})
        values.update(overrides)
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown navmesh setting(s) {unknown}; known: {sorted(known)}")
        return cls(**{k: (float(v) if isinstance(v, (int, float)) and not isinstance(v, bool)
                          and k not in TEXT else v)
                      for k, v in values.items()})

    @property
    def step_tolerance(self) -> float:
        """The largest rise or drop between neighbouring points of a surface that the agent moves across (m): max_climb
        and the surface heights' resolution. Under the habitat profile, what Recast links: surfaces whose heights,
        rounded to its 0.2 m voxels, differ by floor(max_climb / 0.2) voxels, truly up to a voxel more (its navmesh
        joined a 0.25 m platform to the floor, and the agent stopped at its edge)."""
        if self.profile == "habitat":
            from rvn_data.navmesh.recast_profile import HABITAT_CELL_HEIGHT, recast_voxels

            return (recast_voxels(self)[0] + 1) * HABITAT_CELL_HEIGHT
        return self.max_climb + self.cell_height

    def to_dict(self) -> dict[str, float]:
        return recorded(asdict(self))


SOURCES = ("auto", "build", "file")
PROFILES = ("rvn", "habitat")
ISLANDS = ("main", "all")
TEXT = ("source", "file", "profile", "islands")  # the settings that are not numbers
SAMPLING = ("islands", "min_island_radius")  # where points are drawn: not part of a navmesh's build


def recorded(navmesh: Mapping[str, Any]) -> dict[str, Any]:
    """Navmesh settings as recorded in episode and run files: `source` and `file` only when
    they differ from their defaults (build, none), `profile` only when it is not "rvn",
    `islands` and `min_island_radius` only with islands=all, so records made before they
    existed match."""
    out = dict(navmesh)
    if out.get("profile", "rvn") == "rvn":
        out.pop("profile", None)
    if out.get("islands", "main") == "main":
        out.pop("islands", None)
        out.pop("min_island_radius", None)
    if out.get("source", "build") == "build" and out.get("file") is None:
        out.pop("source", None)
        out.pop("file", None)
    return out
