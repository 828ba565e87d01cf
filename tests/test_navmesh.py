"""Navigation mesh on analytic box scenes (areas, gaps, layers, steps, geodesics) and on
the real dream_apartment scene."""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import box_scene, room_boxes
from rvn_data.navmesh import GeodesicField, NavMesh, NavMeshSettings
from rvn_data.scenes import Part, Scene, SceneError, load_scene

R = 0.18


@pytest.mark.parametrize("origin", [(0.0, 0.0), (0.013, 0.031)])
def test_empty_room_area(origin):
    nm = NavMesh.build(box_scene(room_boxes(origin=origin)))
    assert nm.island_areas == pytest.approx([(4 - 2 * R) ** 2], rel=0.02)
    ox, oz = origin
    assert nm.is_navigable(np.array([ox + 2.0, 0.0, oz + 2.0]))
    assert nm.is_navigable(np.array([ox + R + 0.01, 0.0, oz + 2.0]))
    assert not nm.is_navigable(np.array([ox + R - 0.01, 0.0, oz + 2.0]))
    assert nm.floor_height(np.array([ox + 2.0, 0.3, oz + 2.0])) == pytest.approx(0.0, abs=0.011)


def _gap_scene(gap: float):
    """4 x 2 m room split by a wall at x = 2 with a doorway of width `gap` centred at z = 1."""
    boxes = room_boxes(4.0, 2.0)
    boxes += [((1.95, 0, 0), (2.05, 2.5, 1 - gap / 2)), ((1.95, 0, 1 + gap / 2), (2.05, 2.5, 2))]
    return NavMesh.build(box_scene(boxes, f"gap{gap}"))


def test_gap_030_impassable_050_passable():
    a, b = np.array([1.0, 0, 1.0]), np.array([3.0, 0, 1.0])
    narrow = _gap_scene(0.30)
    assert narrow.island_of(a) >= 0 and narrow.island_of(b) >= 0
    assert narrow.island_of(a) != narrow.island_of(b)
    assert narrow.geodesic_distance(a, b) == math.inf
    wide = _gap_scene(0.50)
    assert wide.island_of(a) == wide.island_of(b) == 0
    assert wide.geodesic_distance(a, b) == pytest.approx(2.0, rel=0.01)


@pytest.mark.parametrize("shift", [0.0, 0.001, -0.001, 0.013, 0.025, 0.049])
def test_doorway_clearance_is_symmetric_under_a_lintel(shift):
    """A 0.9 m doorway with a lintel 2 m up (above the agent): both jambs keep the agent
    radius, at any sub-cell offset (the lintel's piece in the jamb's cell is above the band)."""
    z0, z1 = 1 + shift - 0.45, 1 + shift + 0.45
    boxes = room_boxes(4.0, 2.0, origin=(shift, shift))
    boxes += [((shift + 1.95, 0, shift), (shift + 2.05, 2.5, z0)),
              ((shift + 1.95, 0, z1), (shift + 2.05, 2.5, shift + 2)),
              ((shift + 1.95, 2.0, z0), (shift + 2.05, 2.5, z1))]  # lintel
    nm = NavMesh.build(box_scene(boxes, "doorway"))
    zs = np.linspace(z0, z1, 1801)
    for x in (1.97, 2.0, 2.03):  # inside the doorway, between the wall's faces
        nav = nm.is_navigable(np.stack([np.full_like(zs, shift + x), np.zeros_like(zs), zs], 1))
        assert nav.any()
        lo, hi = zs[nav].min() - z0, z1 - zs[nav].max()
        assert lo == pytest.approx(R, abs=0.005) and hi == pytest.approx(R, abs=0.005), (x, lo, hi)


def test_low_table_blocks_high_overhang_does_not():
    table = [((1.0, 0.67, 1.0), (2.0, 0.70, 2.0))] + [  # top and four 4 cm legs
        ((x, 0, z), (x + 0.04, 0.67, z + 0.04)) for x in (1.0, 1.96) for z in (1.0, 1.96)]
    shelf = [((2.5, 1.2, 1.0), (3.5, 1.25, 2.0))]  # overhang held by nothing below 1.2 m
    nm = NavMesh.build(box_scene(room_boxes() + table + shelf))
    assert not nm.is_navigable(np.array([1.5, 0.0, 1.5]))  # under the table
    assert not nm.is_navigable(np.array([1.0 - R + 0.02, 0.0, 1.5]))  # closer than r to the top
    assert nm.is_navigable(np.array([1.0 - R - 0.02, 0.0, 1.5]))
    assert nm.is_navigable(np.array([3.0, 0.0, 1.5]))  # under the 1.2 m overhang
    assert nm.island_areas[0] == pytest.approx((4 - 2 * R) ** 2 - (1 + 2 * R) ** 2 + (4 - math.pi) * R ** 2,
                                               rel=0.02)


def test_thin_pillar_blocks_its_cells():
    pillar = [((2.011, 0, 2.011), (2.041, 2.5, 2.041))]  # 3 cm, off the cell grid
    nm = NavMesh.build(box_scene(room_boxes() + pillar))
    c = np.array([2.026, 0.0, 2.026])
    for ang in np.linspace(0, 2 * math.pi, 12, endpoint=False):
        d = np.array([math.cos(ang), 0, math.sin(ang)])
        assert not nm.is_navigable(c + d * (0.015 + R - 0.02))
        assert nm.is_navigable(c + d * (0.015 * math.sqrt(2) + R + 0.02))


def _box_distance(boxes, x, z):
    """Distance from points (x, z) to the nearest of x/z boxes [(x0, x1, z0, z1), ...]: brute force."""
    d = np.full(np.shape(x), np.inf)
    for x0, x1, z0, z1 in boxes:
        dx, dz = np.maximum(np.maximum(x0 - x, x - x1), 0), np.maximum(np.maximum(z0 - z, z - z1), 0)
        d = np.minimum(d, np.hypot(dx, dz))
    return d


def test_thin_posts_keep_the_agent_radius():
    """Two 7 mm posts: the cell whose centre is nearest a point is not always the cell whose box is (the
    clearance was once the distance to that cell's box and its 8 neighbours', up to 5 cm too large here:
    cells 0.175 m and points 0.142 m from a post counted navigable). Navigable cell centres keep the
    agent radius from every box, navigable points (bilinear clearance) within 3 mm of it."""
    posts = [((2.242, 0, 2.02), (2.249, 2.5, 2.03)), ((2.201, 0, 2.052), (2.208, 2.5, 2.059))]
    nm = NavMesh.build(box_scene(room_boxes() + posts, "posts"))
    boxes = [(0, 4, -1, 0), (0, 4, 4, 5), (-1, 0, 0, 4), (4, 5, 0, 4)] + [(a[0], b[0], a[2], b[2]) for a, b in posts]
    g = nm.grid(0)
    centres = g.grid_to_world(np.argwhere(g.navigable))
    assert _box_distance(boxes, centres[:, 0], centres[:, 2]).min() >= R - 1e-4
    x, z = np.meshgrid(np.arange(1.8, 2.65, 0.004), np.arange(1.6, 2.5, 0.004))
    pts = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], 1)
    near = _box_distance(boxes, pts[:, 0], pts[:, 2])
    nav = nm.is_navigable(pts)
    assert near[nav].min() >= R - 0.003
    assert nav[near > R + 0.01].all()  # and no more than that is eroded


def test_clearance_is_the_distance_to_the_nearest_box(rng):
    """`_clearance` against the brute-force minimum over every obstacle box (thin and whole boxes clipped
    into random cells, some dense, some sparse), below its reach exactly, beyond it within sqrt(2) cells."""
    from rvn_data.navmesh.build import _clearance

    cs, x0, z0 = 0.05, 0.3, -1.2
    for density in (0.001, 0.01, 0.05, 0.3):
        rows, cols = 40, 60
        box = np.full((rows, cols, 4), np.nan, np.float32)
        r, c = np.nonzero(rng.random((rows, cols)) < density)
        lo, hi = np.sort(rng.random((2, len(r), 2)), axis=0)
        thin = rng.random(len(r)) < 0.7
        hi[thin] = lo[thin] + 0.15 * rng.random((thin.sum(), 2))
        box[r, c] = np.stack([x0 + (c + lo[:, 0]) * cs, x0 + (c + hi[:, 0]) * cs,
                              z0 + (r + lo[:, 1]) * cs, z0 + (r + hi[:, 1]) * cs], 1)
        xc, zc = x0 + (np.arange(cols) + 0.5) * cs, z0 + (np.arange(rows) + 0.5) * cs
        ref = _box_distance(box[r, c].astype(np.float64), xc[None, :], zc[:, None])
        for chunk in (1 << 20, 50):
            got = _clearance(box, xc, zc, cs, 0.6, chunk=chunk)
            assert np.array_equal(got[ref < 0.6], ref[ref < 0.6]), density
            assert (got >= ref).all() and (got <= ref + math.sqrt(2) * cs + 1e-9).all()


def test_snap_keeps_a_point_on_its_own_floor():
    """A ground-floor point off the navmesh (in a ground obstacle) under an upper storey snaps to the ground floor
    0.68 m away, not to the storey 2.4 m above whose edge is horizontally nearer: 3-D distance, as Detour's
    findNearestPoly (it ranked by horizontal distance; `Simulator.reset` then put the robot upstairs)."""
    boxes = room_boxes(8.0, 4.0, height=5.0)
    boxes += [((1.0 + 0.25 * k, 0, 0), (1.25 + 0.25 * k, 0.15 * (k + 1), 1.2)) for k in range(16)]  # stairs
    boxes += [((5.0, 2.3, 0), (8.0, 2.4, 4.0)), ((6.0, 0.0, 1.5), (7.0, 1.0, 2.5))]  # the storey, a box under it
    nm = NavMesh.build(box_scene(boxes, "two-storey"))
    snapped = nm.snap(np.array([6.5, 0.0, 2.0]))
    assert snapped[1] == pytest.approx(0.0, abs=0.05) and nm.is_navigable(snapped)


def test_geodesic_detour_around_wall():
    wall = [((1.95, 0, 0), (2.05, 2.5, 3.0))]  # from the z = 0 wall up to z = 3, 1 m gap
    nm = NavMesh.build(box_scene(room_boxes() + wall))
    a, b = np.array([1.0, 0, 1.0]), np.array([3.0, 0, 1.0])
    # analytic: tangents from a and b to the margin circles (radius R) around the wall end
    c1 = np.array([1.95, 3.0])
    d1 = np.hypot(*(np.array([1.0, 1.0]) - c1))
    tangent = math.sqrt(d1 ** 2 - R ** 2)
    phi_a = math.atan2(1.0 - 3.0, 1.0 - 1.95)
    t_ang = phi_a - math.acos(R / d1)  # tangent point on the far side of the circle
    arc = R * abs(((t_ang - math.pi / 2) + math.pi) % (2 * math.pi) - math.pi)
    analytic = 2 * tangent + 2 * arc + 0.1
    geo = nm.geodesic_distance(a, b)
    assert geo > np.linalg.norm(a - b) + 1.0
    assert geo == pytest.approx(analytic, rel=0.03)
    field = nm.distance_field(b)
    assert field.distance(a) == pytest.approx(analytic, rel=0.03)
    assert field.distance(b) == pytest.approx(0.0, abs=1e-9)
    assert field.distance(np.stack([a, b])).shape == (2,)
    path = nm.shortest_path(a, b)
    assert np.allclose(path[0], a) and np.allclose(path[-1], b)
    assert all(nm.is_navigable(p) for p in path)


def test_step_015_climbable_030_not():
    for h, same in ((0.15, True), (0.30, False)):
        step = [((2.0, 0, 0), (4.0, h, 4.0))]
        nm = NavMesh.build(box_scene(room_boxes() + step))
        lo, hi = np.array([1.0, 0, 2.0]), np.array([3.0, h, 2.0])
        assert nm.is_navigable(lo) and nm.is_navigable(hi)
        assert (nm.island_of(lo) == nm.island_of(hi)) is same
        assert nm.floor_height(hi) == pytest.approx(h, abs=0.011)
        assert math.isfinite(nm.geodesic_distance(lo, hi)) is same


def test_second_storey_is_its_own_surface():
    upper = [((0.5, 2.9, 0.5), (3.5, 3.0, 3.5))]  # a slab 3 m up, over the room
    nm = NavMesh.build(box_scene(room_boxes(height=2.5) + upper))
    down, up = np.array([2.0, 0.0, 2.0]), np.array([2.0, 3.0, 2.0])
    assert nm.is_navigable(down) and nm.is_navigable(up)
    assert nm.island_of(down) != nm.island_of(up)
    assert nm.floor_height(up) == pytest.approx(3.0, abs=0.011)
    assert nm.floor_height(down) == pytest.approx(0.0, abs=0.011)
    assert len(nm.layers) == 2


def test_sample_snap_grid(rng):
    nm = NavMesh.build(box_scene(room_boxes()))
    pts = np.stack([nm.sample(rng) for _ in range(50)])
    assert nm.is_navigable(pts).all()
    again = np.stack([nm.sample(np.random.default_rng(0)) for _ in range(1)])
    assert np.array_equal(again[0], pts[0])
    snapped = nm.snap(np.array([0.05, 0.4, 2.0]))
    assert nm.is_navigable(snapped) and snapped[0] == pytest.approx(R, abs=0.01)
    assert np.isnan(nm.snap(np.array([20.0, 0.0, 20.0]))).all()
    g = nm.grid(0)
    rc = g.world_to_grid(np.array([2.0, 0.0, 2.0]))
    assert g.navigable[rc[0], rc[1]]
    assert np.allclose(g.grid_to_world(rc)[[0, 2]], 2.0, atol=g.cs)
    assert g.occupancy(0.1).sum() > g.occupancy(0.3).sum() > 0
    with pytest.raises(ValueError, match="island"):
        nm.sample(rng, island=3)


def test_bad_input_errors():
    with pytest.raises(ValueError, match="agent_radius"):
        NavMeshSettings(agent_radius=-0.1)
    with pytest.raises(ValueError, match="cell_size"):
        NavMeshSettings(cell_size=0)
    quad = np.array([[0, 0, 0], [0, 0, 3], [0, 2, 3], [0, 2, 0]], float)  # one vertical wall
    wall_only = Scene("wall-only", [Part("wall", quad, [[0, 1, 2], [0, 2, 3]])])
    with pytest.raises(SceneError, match="wall-only.*no walkable surface"):
        NavMesh.build(wall_only, NavMeshSettings())
    with pytest.raises(SceneError, match="tiny.*island"):
        NavMesh.build(box_scene(room_boxes(0.8, 0.8), "tiny"))


def test_dream_apartment(dream_path):
    scene = load_scene(dream_path)
    nm = NavMesh.build(scene)
    assert 15.0 <= nm.navigable_area <= 30.0
    assert nm.island_areas == sorted(nm.island_areas, reverse=True)
    main = nm.grid(0)
    rows, cols = np.nonzero(main.island == 0)
    pts = main.grid_to_world(np.stack([rows, cols], -1))
    assert pts[:, 0].min() > 4.0  # the stray meshes float near x = 0.5
    assert np.nanmax(np.abs(pts[:, 1])) < 0.05  # the floor, not a wall top


def test_stairs_to_an_upper_floor_over_the_lower_one():
    boxes = room_boxes(8.0, 4.0, height=5.0)
    boxes += [((1.0 + 0.25 * k, 0, 0), (1.25 + 0.25 * k, 0.15 * (k + 1), 1.2)) for k in range(16)]
    boxes += [((5.0, 2.3, 0), (8.0, 2.4, 4.0))]  # upper floor reached by the stairs
    nm = NavMesh.build(box_scene(boxes, "two-storey"))
    low, under, up = np.array([0.5, 0, 3.0]), np.array([6.5, 0, 2.0]), np.array([6.5, 2.4, 2.0])
    assert nm.island_of(low) == nm.island_of(under) == nm.island_of(up) == 0
    assert nm.floor_height(up) == pytest.approx(2.4, abs=0.011)
    assert nm.floor_height(under) == pytest.approx(0.0, abs=0.011)
    geo = nm.geodesic_distance(low, up)
    assert geo > 4.0 + 2.0  # must climb the 4 m stairs, cannot go straight
    assert nm.distance_field(up).distance(low) == pytest.approx(geo, rel=0.03)
    assert nm.geodesic_distance(low, under) == pytest.approx(np.hypot(6.0, 1.0), rel=0.01)
    path = nm.shortest_path(low, up)
    assert (np.diff(path[:, 1]) >= -0.011).all() and path[-1, 1] == pytest.approx(2.4, abs=0.011)


def _whole_field(nm: NavMesh, goal: np.ndarray, dtype=np.float64) -> GeodesicField:
    """The field smoothed at every node in order of Dijkstra distance (each node after its tree parent, as
    the smoothing was done before fields were smoothed where read), as ``dtype``, with no tree to fill."""
    from rvn_data.navmesh.geodesic import _smooth_node, run_dijkstra

    graph, _, centres, cells = nm._ensure_graph()
    tree, P = nm.distance_field(goal, keep=False).tree, nm.packed
    dist = run_dijkstra(graph, tree.root)
    out, parent = np.full(len(dist), np.inf), np.full(len(dist), -1, np.int64)
    for v in np.argsort(dist)[:int(np.isfinite(dist).sum())]:
        _smooth_node(v, tree.pred, cells, centres, P.meta, P.clearance, P.island, tree.goal, *tree.grid,
                     nm.settings.agent_radius - 1e-6, out, parent)
    return GeodesicField(nm, tree.goal, out.astype(dtype))


def _field_read_at_points(nm: NavMesh, rng: np.random.Generator, sources: int = 6, n: int = 32) -> int:
    """A field smoothed where it is read gives the very numbers of the whole field, whatever is read
    first: at navigable samples, points pushed off them (walls, gaps, off the mesh) and one beside the
    source, read one by one in reverse order or all at once; also a goal pool's float32 copy. Returns
    how many distances were finite."""
    finite = 0
    for _ in range(sources):
        s = nm.sample(rng)
        pts = np.array([nm.sample(rng) for _ in range(n)])
        pts[::4, [0, 2]] += rng.normal(0.0, 0.3, (len(pts[::4]), 2))
        pts[1] = s + np.array([0.03, 0.0, -0.02])
        whole = _whole_field(nm, s).distance(pts)
        one_by_one = nm.distance_field(s, keep=False)
        assert np.array_equal([one_by_one.distance(p) for p in pts[::-1]][::-1], whole)
        assert np.array_equal(nm.distance_field(s, keep=False).distance(pts), whole)
        assert np.array_equal(one_by_one.distance(pts), whole)  # read again: nothing changes
        tree = nm.distance_field(s, keep=False).tree
        pooled = GeodesicField(nm, tree.goal, np.full(len(tree.pred), np.inf, np.float32), tree)
        assert np.array_equal(pooled.distance(pts), _whole_field(nm, s, np.float32).distance(pts))
        finite += int(np.isfinite(whole).sum())
    return finite


def test_field_read_at_points_equals_the_whole_field():
    from rvn_data.scenes.procedural import make_apartment

    rng = np.random.default_rng(3)
    for split, i in [("train", 0), ("val", 1)]:
        nm = NavMesh.build(make_apartment(split, i))
        assert _field_read_at_points(nm, rng) > 150
    boxes = room_boxes(8.0, 4.0, height=5.0)  # two storeys (the stairs test's scene): several layers
    boxes += [((1.0 + 0.25 * k, 0, 0), (1.25 + 0.25 * k, 0.15 * (k + 1), 1.2)) for k in range(16)]
    boxes += [((5.0, 2.3, 0), (8.0, 2.4, 4.0))]
    nm = NavMesh.build(box_scene(boxes, "two-storey"))
    assert len(nm.layers) > 1 and _field_read_at_points(nm, rng) > 100
    nm = NavMesh.build(box_scene(room_boxes(20.0, 1.0), "corridor"))  # a chain longer than fill_chains' first buffer
    a, b = np.array([0.3, 0.0, 0.5]), np.array([19.7, 0.0, 0.5])
    field = nm.distance_field(a, keep=False)
    depth, v = 0, nm._node(b)
    while v != field.tree.root:
        depth, v = depth + 1, field.tree.pred[v]
    assert depth > 256 and field.distance(b) == _whole_field(nm, a).distance(b) == pytest.approx(19.4, abs=0.05)


def test_field_sets_solve_together_smoothed_whole_and_pickle_with_their_values():
    """`FieldTrees` (a goal pool's fields, their solves in one call) holds the fields of `distance_field(goal,
    keep=False)` one by one (trees, snapped goals; inf for a goal with no graph node), smoothed whole: the distances
    each field gives smoothed where it is read, bit for bit, and no read smooths again. Pickled (a helper process
    sends pools so) with its values but not the rest of the smoothing state: the same distances. With
    ``smooth=False`` lookups smooth where they read, as a single field does, and it pickles without values."""
    import pickle

    from rvn_data.navmesh.field_sets import FieldTrees, fields_distance

    nm = NavMesh.build(load_scene("procedural:val/0"))
    rng = np.random.default_rng(4)
    goals = [nm.sample(rng) + [0.02, 0.0, 0.0] for _ in range(5)] + [np.array([500.0, 0.0, 500.0])]
    one_by_one = [nm.distance_field(g, keep=False) for g in goals]
    assert one_by_one[-1].tree is None and one_by_one[0].tree is not None
    stack = FieldTrees(nm, goals, dtype=np.float64)  # float64 values, as a field of its own
    lazy = FieldTrees(nm, goals, dtype=np.float64, smooth=False)
    assert np.array_equal(stack.goals, [f.goal for f in one_by_one])
    for tree, ref in zip(stack.trees, one_by_one[:-1]):
        assert np.array_equal(tree.pred, ref.tree.pred) and tree.pred.dtype == ref.tree.pred.dtype
        assert (tree.root, tree.grid) == (ref.tree.root, ref.tree.grid)
    assert (stack.trees[-1].pred == -1).all() and stack.trees[-1].root == -1
    reached = (stack.pred >= 0) | (np.arange(stack.pred.shape[1]) == stack.roots[:, None])
    assert np.isfinite(stack.out[reached]).all() and np.isinf(stack.out[~reached]).all()
    assert np.isinf(lazy.out).all()
    points = [nm.sample(rng) for _ in range(6)]
    fresh, done = pickle.loads(pickle.dumps(stack)), stack.out.copy()
    for p in points[:3]:
        for s in (stack, lazy):
            assert np.array_equal(fields_distance(nm, s, p), [f.distance(p) for f in one_by_one])
            assert fields_distance(nm, s, p)[-1] == np.inf
    assert np.array_equal(stack.out, done)  # nothing smoothed at the reads
    read = np.isfinite(lazy.out)
    assert 0 < read.sum() < reached.sum() and np.array_equal(lazy.values[read], stack.values[read])
    assert len(pickle.dumps(stack)) < stack.pred.nbytes + stack.values.nbytes + 4096 < stack.nbytes
    assert len(pickle.dumps(lazy)) < lazy.pred.nbytes + 4096  # the predecessors and the goals
    for copy in (fresh, pickle.loads(pickle.dumps(lazy))):
        assert copy.values.dtype == np.float64 and (copy.parent == -1).all()
        assert all(np.shares_memory(t.out, copy.out) and np.shares_memory(t.pred, copy.pred) for t in copy.trees)
        for p in points:
            assert np.array_equal(fields_distance(nm, copy, p), [f.distance(p) for f in one_by_one])
        assert [t.grid for t in copy.trees] == [t.grid for t in stack.trees]
    assert np.array_equal(fresh.values, stack.values) and np.array_equal(np.isfinite(fresh.out), reached)
