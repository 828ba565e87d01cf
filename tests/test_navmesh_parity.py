"""benchmarks/navmesh_parity.py: its figures on a navmesh against itself, the habitat profile
against the Recast-baked box room fixture, and its command line on one procedural val scene
with the committed Recast fixture."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import box_scene
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.navmesh.source import load_navmesh_file

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import navmesh_parity  # noqa: E402

DATA = Path(__file__).parent / "data"
ROOM = [((-0.1, -0.1, -0.1), (4.1, 0.0, 4.1)), ((-0.1, 0, -0.1), (0, 4, 4.1)), ((4, 0, -0.1), (4.1, 4, 4.1)),
        ((-0.1, 0, -0.1), (4.1, 4, 0)), ((-0.1, 0, 4), (4.1, 4, 4.1)), ((1.9, 0, 0), (2.1, 4, 3)),
        ((2.6, 0, 0.4), (3.6, 0.1, 1.4)), ((0.0, 2.3, 0.0), (1.8, 2.4, 1.8))]  # tests/data/make_recast_navmesh.mjs


def test_a_navmesh_against_itself():
    scene = box_scene(ROOM, "room")
    nm = NavMesh.build(scene, NavMeshSettings(agent_height=1.5))
    f = navmesh_parity.compare(nm, nm, scene, np.random.default_rng(0), n_pairs=30)
    assert f["area_ratio"] == 1.0 and f["pairs"] == 30
    assert f["geo_median_pct"] == f["geo_p95_pct"] == 0.0 and f["mismatch"] == 0.0 and f["grid_disagree"] == 0.0


def test_habitat_profile_matches_the_recast_room():
    """The room baked by real Recast (tests/data/recast_room_solo.navmesh): the habitat profile
    is within the issue's goals, the rvn profile's area is larger (exact 0.18 m edge)."""
    scene = box_scene(ROOM, "room")
    st = dict(agent_height=1.5, min_island_area=0.1)
    ref = load_navmesh_file(DATA / "recast_room_solo.navmesh", NavMeshSettings(**st), scene)
    hab = navmesh_parity.compare(NavMesh.build(scene, NavMeshSettings(profile="habitat", **st)), ref, scene,
                                 np.random.default_rng(0), n_pairs=40)
    rvn = navmesh_parity.compare(NavMesh.build(scene, NavMeshSettings(**st)), ref, scene,
                                 np.random.default_rng(0), n_pairs=40)
    assert all(navmesh_parity.passes(hab).values()), hab
    assert hab["grid_disagree"] < 0.02
    assert rvn["area_ratio"] > 1.05


def test_cli_on_a_procedural_scene(capsys):
    navmesh_parity.main(["--scenes", "procedural:val/3", "--profiles", "habitat", "--pairs", "30"])
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("procedural:val/3"))
    ratio = float(row.split()[4])
    assert 0.98 <= ratio <= 1.02, row
    assert "area ratio PASS" in out and "mismatch PASS" in out, out


@pytest.mark.slow
def test_each_profile_is_judged_against_its_own_goals(capsys):
    """Issue 35: the rvn profile was judged by the habitat profile's goals (four FAIL lines by
    design); now its summary is information, and FAIL (exit status 1) means a real failure."""
    status = navmesh_parity.main(["--scenes", "procedural:val/3", "--profiles", "rvn,habitat", "--pairs", "10"])
    lines = capsys.readouterr().out.splitlines()
    rvn = float(next(ln for ln in lines if ln.startswith("procedural:val/3") and ln.split()[1] == "rvn").split()[4])
    assert rvn > 1.05  # outside the habitat goals, as designed
    assert "FAIL" not in "\n".join(lines) and status == 0, lines
    assert "         information only (no goals against Recast: exact-radius erosion, larger than Recast's whole cells " \
           "by design)" in lines
    assert "         goals of the habitat profile: area ratio PASS, geodesic median PASS, geodesic p95 PASS, " \
           "mismatch PASS" in lines
    bad = dict(area_ratio=1.2, geo_median_pct=0.1, geo_p95_pct=0.5, mismatch=0.0)  # a habitat row off its area goal
    assert navmesh_parity.verdict("habitat", [bad]) == (
        "         goals of the habitat profile: area ratio FAIL, geodesic median PASS, geodesic p95 PASS, mismatch PASS",
        False)


def test_bake_needs_the_packages(tmp_path):
    with pytest.raises(SystemExit, match="needs node|node_modules has no @recast-navigation"):
        navmesh_parity.main(["--scenes", "procedural:val/3", "--bake", "--recast-dir", str(tmp_path)])
