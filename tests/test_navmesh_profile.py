"""`navmesh.profile=habitat`: Recast's build semantics on analytic box scenes (radius rounded
up to whole cells from the cells an obstacle touches, narrow gaps closed, climb in 0.2 m
voxels, true floor heights), the setting's validation and record, and `rvn-scene --profile`."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from conftest import box_scene, room_boxes
from rvn_data.cli.scene import main
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.navmesh.settings import recorded

R = 0.18
HAB = NavMeshSettings(profile="habitat")


def _edge_from(nm, x_face, z, direction):
    """Distance from an obstacle face at x = x_face to the first navigable point along +x/-x."""
    xs = x_face + direction * np.linspace(0.0, 0.6, 1201)
    nav = nm.is_navigable(np.stack([xs, np.zeros_like(xs), np.full_like(xs, z)], 1))
    assert nav.any()
    return float(np.abs(xs[np.argmax(nav)] - x_face))


@pytest.mark.parametrize("shift", [0.0, 0.013, 0.031, 0.049])
def test_edge_lies_whole_cells_from_the_touched_cells(shift):
    """A pillar off the grid: Recast's edge is ceil(r / cs) = 4 cells from the cells the pillar
    touches, so 0.20-0.25 m from its faces (RVN's exact edge: 0.18 m)."""
    pillar = [((2.0 + shift, 0, 1.5), (2.3 + shift, 2.5, 2.5))]
    hab = NavMesh.build(box_scene(room_boxes() + pillar), HAB)
    rvn = NavMesh.build(box_scene(room_boxes() + pillar))
    for face, direction in ((2.0 + shift, -1), (2.3 + shift, +1)):
        d = _edge_from(hab, face, 2.0, direction)
        assert 0.20 - 1e-3 <= d <= 0.25 + 1e-3, (face, d)
        assert _edge_from(rvn, face, 2.0, direction) == pytest.approx(R, abs=0.003)
    assert hab.navigable_area < rvn.navigable_area


def test_room_area_is_whole_cells():
    """Walls on cell boundaries (Recast's grid starts at the bounds minimum): a face on a
    cell's lower boundary touches that cell, one on its upper boundary does not, so the edge
    lies 0.25 m from the walls at x = 0 and z = 0 and 0.20 m from those at x = 4 and z = 4:
    the area is (4 - 0.45)² exactly (Recast's kept cells), as real Recast bakes it."""
    nm = NavMesh.build(box_scene(room_boxes()), HAB)
    assert nm.island_areas == pytest.approx([(4 - 0.45) ** 2], abs=1e-6)
    assert _edge_from(nm, 0.0, 2.0, +1) == pytest.approx(0.25, abs=1e-3)
    assert _edge_from(nm, 4.0, 2.0, -1) == pytest.approx(0.20, abs=1e-3)
    assert nm.floor_height(np.array([2.0, 0.3, 2.0])) == pytest.approx(0.0, abs=1e-6)  # not the 0.2 m voxel top


@pytest.mark.parametrize("gap, rvn_open, hab_open", [(0.41, True, False), (0.45, True, False), (0.60, True, True)])
def test_narrow_gaps_close(gap, rvn_open, hab_open):
    """rvn opens a gap of 2 r + cs or more (a cell centre lies in the 5 cm band r from both jambs, whatever
    the grid's offset); one between 2 r and 2 r + cs opens where the band holds a cell centre. Here 0.40 m
    does not: the centres 2.5 cm either side of the gap's middle are 0.175 m from a jamb (it opened when the
    clearance was measured to the far side of a jamb's cell, a cell too far)."""
    boxes = room_boxes(4.0, 2.0) + [((1.95, 0, 0), (2.05, 2.5, 1 - gap / 2)),
                                    ((1.95, 0, 1 + gap / 2), (2.05, 2.5, 2))]
    a, b = np.array([1.0, 0, 1.0]), np.array([3.0, 0, 1.0])
    for settings, is_open in ((NavMeshSettings(), rvn_open), (HAB, hab_open)):
        nm = NavMesh.build(box_scene(boxes, f"gap{gap}"), settings)
        assert math.isfinite(nm.geodesic_distance(a, b)) is is_open, (settings.profile, gap)


def test_climb_is_in_voxels_of_recast():
    """Floor top at y = 0 with the bounds 0.1 m below: Recast's floor voxel top is 1, a 0.25 m
    step's is 2 (one voxel up: climbable), a 0.45 m step's is 3 (not). RVN: 0.2 m exactly."""
    lo = np.array([1.0, 0, 2.0])
    for h, hab_same, rvn_same in ((0.25, True, False), (0.45, False, False), (0.15, True, True)):
        step = [((2.0, 0, 0), (4.0, h, 4.0))]
        hi = np.array([3.0, h, 2.0])
        for settings, same in ((HAB, hab_same), (NavMeshSettings(), rvn_same)):
            nm = NavMesh.build(box_scene(room_boxes() + step), settings)
            assert nm.is_navigable(lo) and nm.is_navigable(hi)
            assert (nm.island_of(lo) == nm.island_of(hi)) is same, (settings.profile, h)
            assert nm.floor_height(hi) == pytest.approx(h, abs=1e-5)


def test_profile_setting_and_record():
    assert "profile" not in recorded(NavMeshSettings().to_dict())
    assert HAB.to_dict()["profile"] == "habitat"
    with pytest.raises(ValueError, match="profile='recast'"):
        NavMeshSettings(profile="recast")
    assert NavMeshSettings.from_config({"profile": "habitat"}) == HAB


def test_rvn_scene_info_profile(capsys):
    main(["info", "procedural:val/0", "--json"])
    rvn = json.loads(capsys.readouterr().out)
    main(["info", "procedural:val/0", "--profile", "habitat", "--json"])
    hab = json.loads(capsys.readouterr().out)
    assert hab["navmesh"]["profile"] == "habitat" and "profile" not in rvn["navmesh"]
    assert 0.7 < hab["islands"][0] / rvn["islands"][0] < 1.0


def test_the_habitat_profile_drives_where_its_navmesh_links():
    """Recast links surfaces whose heights, rounded to 0.2 m voxels, are within its climb: a 0.25 m platform joins the
    floor under the habitat profile (one island, a finite geodesic), and the agent drives up it as habitat-sim's would
    along the polygons (it stopped at the edge, colliding at every step, the simulator allowing max_climb + a cell).
    The rvn profile keeps the platform apart, as before."""
    from rvn_data.conventions import Action
    from rvn_data.sim import Simulator

    boxes = room_boxes(6.0, 4.0) + [((3.0, 0, 0), (6.0, 0.25, 4.0))]
    a, b = np.array([1.5, 0, 2.0]), np.array([4.5, 0.25, 2.0])
    for profile, islands, reached in (("habitat", 1, True), ("rvn", 2, False)):
        nm = NavMesh.build(box_scene(boxes, "platform"), NavMeshSettings(profile=profile))
        assert nm.num_islands == islands and np.isfinite(nm.geodesic_distance(a, b)) == reached
        sim = Simulator(nm)
        sim.reset(a, 0.0)
        collided = [sim.step(Action.MOVE_FORWARD).collided for _ in range(12)]
        assert (sim.position[0] == pytest.approx(4.5) and sim.position[1] == pytest.approx(0.25) and not any(collided)) \
            == reached, (profile, sim.position, collided)
