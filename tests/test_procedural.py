"""Procedural apartments: determinism, split disjointness, budgets, layout, navigability."""
from __future__ import annotations

import hashlib

import numpy as np
import pytest

from rvn_data.scenes import SceneError
from rvn_data.scenes import meshing
from rvn_data.scenes.procedural import SPLITS, describe_apartment, make_apartment, parse_scene_id


def scene_digest(scene) -> str:
    h = hashlib.sha256(scene.scene_id.encode())
    for p in scene.parts:
        h.update(p.name.encode())
        h.update(repr(p.base_color).encode())
        for a in (p.vertices, p.faces, p.uv, p.colors, p.texture):
            h.update(b"-" if a is None else a.tobytes() + str(a.shape).encode())
    return h.hexdigest()


def test_same_split_index_gives_identical_bytes():
    for split, index in (("train", 7), ("val", 3), ("test", 49)):
        a, b = make_apartment(split, index), make_apartment(split, index)
        assert a.scene_id == f"procedural:{split}/{index}"
        assert scene_digest(a) == scene_digest(b)
        assert describe_apartment(split, index) == describe_apartment(split, index)


def test_splits_and_indices_differ():
    digests = {scene_digest(make_apartment(s, i)) for s in SPLITS for i in (0, 1)}
    assert len(digests) == 6
    # Disjoint by construction: the x size in decimetres is the split's code mod 3.
    for split, (code, _) in SPLITS.items():
        for i in range(8):
            info = describe_apartment(split, i)
            assert round(info.footprint_m[0] * 10) % 3 == code


def test_footprint_matches_scene_bounds():
    info = describe_apartment("val", 5)
    b = make_apartment("val", 5).bounds
    assert np.allclose(b[1, [0, 2]] - b[0, [0, 2]], np.array(info.footprint_m) + 0.1, atol=1e-3)
    assert b[0, 1] == pytest.approx(0.0) and b[1, 1] == pytest.approx(info.wall_height)


def test_layout_ranges_over_a_sample():
    kinds = set()
    for split, i in [("train", i) for i in range(0, 800, 67)] + [("val", 11), ("test", 23)]:
        info = describe_apartment(split, i)
        assert 3 <= info.num_rooms <= 8, info
        assert 10 <= info.num_furniture <= 40, info
        assert 40.0 <= info.area_m2 <= 120.0, info
        assert 2.5 <= info.wall_height <= 2.8
        assert info.num_doors >= info.num_rooms - 1
        assert all(0.8 <= w <= 1.0 for w in info.door_widths_m)
        assert len(set(info.furniture)) >= 4
        kinds |= set(info.furniture)
    for kind in ("dining_table", "chair", "bed", "sofa", "bookshelf", "wardrobe", "counter", "plant_stand",
                 "floor_lamp"):
        assert kind in kinds


def test_triangle_budget_and_part_arrays():
    for split, i in (("train", 0), ("train", 399), ("val", 49), ("test", 17)):
        scene = make_apartment(split, i)
        assert 1000 < scene.num_triangles <= 60_000
        assert len(scene.parts) <= 12
        assert len({p.name for p in scene.parts}) == len(scene.parts)
        for p in scene.parts:
            assert p.faces.min() >= 0 and p.faces.max() < len(p.vertices)
            assert p.uv.shape == (len(p.vertices), 2) and p.colors.shape == (len(p.vertices), 4)
            if p.texture is not None:
                assert p.texture.dtype == np.uint8 and p.texture.ndim == 3 and p.texture.shape[2] == 3
        names = {p.name for p in scene.parts}
        assert {"walls", "ceiling", "painted"} <= names and names & {"floor_wood", "floor_tile", "floor_carpet"}


def _normals(v, f):
    t = v[f].astype(np.float64)
    return np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), t.mean(1)


def test_primitives_wind_counter_clockwise_from_outside():
    v, f, uv, _ = meshing.boxes([[0, 0, 0, 1, 2, 3], [5, 0, 5, 5.5, 0.1, 7]], [(1, 2, 3)] * 2, tile=1.0)
    n, c = _normals(v, f)
    centre = np.repeat(np.array([[0.5, 1, 1.5], [5.25, 0.05, 6]]), 12, axis=0)
    assert np.all(np.einsum("ij,ij->i", n, c - centre) > 0)
    assert uv.shape == (48, 2)
    v, f, _, _ = meshing.cylinders([[1, 2, 0.3, 0.0, 1.0]], [(0, 0, 0)], tile=1.0, segments=10)
    n, c = _normals(v, f)
    assert len(f) == 40
    assert np.all(np.einsum("ij,ij->i", n, c - np.array([1, 0.5, 2])) > 0)


def test_floors_face_up_and_ceiling_faces_down():
    scene = make_apartment("train", 12)
    for p in scene.parts:
        if p.name.startswith("floor") or p.name == "ceiling":
            n, _ = _normals(p.vertices, p.faces)
            assert np.all(np.sign(n[:, 1]) == (-1 if p.name == "ceiling" else 1))


@pytest.mark.parametrize("split,index,match", [
    ("dev", 0, "valid splits are train, val, test"),
    ("train", 800, r"0\.\.799"),
    ("val", -1, r"0\.\.49"),
    ("test", 50, r"0\.\.49"),
    ("test", 1.5, r"0\.\.49"),
])
def test_bad_split_or_index_raises_scene_error(split, index, match):
    with pytest.raises(SceneError, match=match):
        make_apartment(split, index)
    with pytest.raises(SceneError, match=match):
        describe_apartment(split, index)


def test_parse_scene_id():
    assert parse_scene_id("procedural:val/12") == ("val", 12)
    for bad in ("procedural:val", "procedural:val/x", "val/3", "procedural:train/900"):
        with pytest.raises(SceneError):
            parse_scene_id(bad)


def test_apartments_form_one_connected_navigable_floor():
    from rvn_data.navmesh import NavMesh, NavMeshSettings

    rng = np.random.default_rng(0)
    for split, i in [("train", 0), ("train", 1), ("train", 2), ("train", 3), ("train", 4), ("val", 0), ("val", 1)]:
        scene = make_apartment(split, i)
        nav = NavMesh.build(scene, NavMeshSettings())
        areas = nav.island_areas
        assert areas[0] >= 15.0 and areas[0] >= 0.85 * sum(areas), (scene.scene_id, areas)
        points = [nav.sample(rng) for _ in range(31)]
        field = nav.distance_field(points[0])
        d = [field.distance(p) for p in points[1:]]
        assert all(np.isfinite(d)), (scene.scene_id, d)  # island 0 is one connected floor
        # goals 4-8 m apart fit: from the first point and from the one farthest from it (the flat's far end), 60
        # distances (from the first alone, 1 to 25 of 30 over seeds 0-7: a source near the middle of a long flat)
        far = nav.distance_field(points[1 + int(np.argmax(d))])
        d += [far.distance(p) for p in points[1:]]
        assert sum(4.0 <= x <= 8.0 for x in d) >= 4, (scene.scene_id, d)  # 5-33 over seeds 0-5
        # Tables, beds and sofas block the floor under them for the 1.0 m robot; so do the
        # thin obstacles (>= 4 cm poles and pillars).
        info = describe_apartment(split, i)
        for kind, (x0, z0, x1, z1) in zip(info.furniture, info.furniture_extents):
            assert min(x1 - x0, z1 - z0) >= 0.04, (kind, x0, z0, x1, z1)
            if kind in ("dining_table", "coffee_table", "desk", "bed", "sofa", "counter", "plant_stand",
                        "floor_lamp", "coat_rack", "pillar"):
                assert not nav.is_navigable(np.array([(x0 + x1) / 2, 0.0, (z0 + z1) / 2])), (scene.scene_id, kind)
