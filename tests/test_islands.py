"""navmesh.islands: starts and goals on the main island (default) or, with islands=all, on every island of radius
>= navmesh.min_island_radius (Habitat's PointNav rule), on a two-storey house: the API, rvn-scene, rvn-gen, rvn-eval
and the RL env."""
import gzip
import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from rvn_data.benchmark.env import RVNEnv
from rvn_data.benchmark.goal_pool import GoalPool
from rvn_data.conventions import AgentConfig
from rvn_data.benchmark.episodes import EpisodeSettings, sample_episodes, settings_record
from rvn_data.dataset.floors import by_floor, floor_grid, floor_heights
from rvn_data.dataset.reader import load_traj_data
from rvn_data.navmesh.disk_cache import build_key
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.navmesh.source import open_scene

T = trimesh.transformations.translation_matrix
UPPER_Y = 3.0  # m, the upper storey's floor


def _box(ext, pos):
    return trimesh.creation.box(extents=ext, transform=T(pos))


def _walls(w, d, y0, h, cx=0.0):
    return [_box((w + 0.2, h, 0.1), (cx, y0 + h / 2, d / 2 + 0.05)), _box((w + 0.2, h, 0.1), (cx, y0 + h / 2, -d / 2 - 0.05)),
            _box((0.1, h, d + 0.2), (cx + w / 2 + 0.05, y0 + h / 2, 0)), _box((0.1, h, d + 0.2), (cx - w / 2 - 0.05, y0 + h / 2, 0))]


def house_glb(path: Path) -> Path:
    """A 10 x 6 m ground floor with a 2 x 1.8 x 0.6 m bed (its top an island of radius ~1.0 m), under a 6 x 5 m upper
    storey whose floor is at 3 m (no stairs: an island of its own), y up."""
    parts = [_box((10.0, 0.02, 6.0), (0, -0.01, 0)), *_walls(10.0, 6.0, 0.0, 2.8), _box((2.0, 0.6, 1.8), (-3.5, 0.3, 1.6)),
             _box((6.0, 0.2, 5.0), (2.0, UPPER_Y - 0.1, 0.0)), *_walls(6.0, 5.0, UPPER_Y, 2.5, cx=2.0)]
    mesh = trimesh.util.concatenate(parts)
    mesh.visual.vertex_colors = np.tile([180, 160, 140, 255], (len(mesh.vertices), 1)).astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)
    return path


def mezzanine_glb(path: Path) -> Path:
    """A 10 x 4 m room with a 3.5 x 4 m mezzanine at 1.2 m over its east end and 8 steps of 0.15 m up to it: one
    island over two floors."""
    parts = [_box((10.0, 0.02, 4.0), (0, -0.01, 0)), *_walls(10.0, 4.0, 0.0, 3.5), _box((3.5, 0.1, 4.0), (3.25, 1.15, 0))]
    for k in range(8):
        parts.append(_box((0.3, 0.15 * (k + 1), 1.4), (1.35 - 0.3 * (7 - k), 0.075 * (k + 1), -1.2)))
    mesh = trimesh.util.concatenate(parts)
    mesh.visual.vertex_colors = np.tile([180, 160, 140, 255], (len(mesh.vertices), 1)).astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)
    return path


@pytest.fixture(scope="module")
def house(tmp_path_factory) -> Path:
    return house_glb(tmp_path_factory.mktemp("house") / "scenes" / "house.glb")


@pytest.fixture(scope="module")
def mezzanine(tmp_path_factory) -> Path:
    return mezzanine_glb(tmp_path_factory.mktemp("mezzanine") / "scenes" / "mezzanine.glb")


def floor_of(y) -> int:
    """0 on the ground floor, 1 upstairs."""
    return int(round(float(y) / UPPER_Y))


def test_the_islands_a_navmesh_draws_on(house):
    _, main = open_scene(str(house), {}, NavMeshSettings())
    _, every = open_scene(str(house), {}, NavMeshSettings(islands="all"))
    assert main.num_islands == 3 and main.island_areas == every.island_areas
    radii, heights = every.island_shapes
    assert radii[0] > 5 and radii[1] > 3 and 0.9 < radii[2] < 1.5  # the bed's top
    assert abs(heights[0]) < 0.01 and abs(heights[1] - UPPER_Y) < 0.01 and abs(heights[2] - 0.6) < 0.01
    assert main.sampled_islands == [0] and every.sampled_islands == [0, 1]
    _, low = open_scene(str(house), {}, NavMeshSettings(islands="all", min_island_radius=0.5))
    assert low.sampled_islands == [0, 1, 2]

    rng = np.random.default_rng(0)
    on = every.island_of(np.stack([every.sample(rng) for _ in range(3000)]))
    share = every.island_areas[1] / (every.island_areas[0] + every.island_areas[1])
    assert set(on.tolist()) == {0, 1} and abs((on == 1).mean() - share) < 0.03  # uniform over their area
    on = main.island_of(np.stack([main.sample(rng) for _ in range(300)]))
    assert set(on.tolist()) == {0}
    assert set(every.island_of(np.stack([every.sample(rng, 1) for _ in range(50)])).tolist()) == {1}


def test_settings_records_and_keys(house):
    assert "islands" not in NavMeshSettings().to_dict()  # episode sets and runs made before keep their keys
    assert NavMeshSettings(islands="main", min_island_radius=3).to_dict() == NavMeshSettings().to_dict()
    assert NavMeshSettings(islands="all").to_dict()["islands"] == "all"
    eps, agent = EpisodeSettings(), AgentConfig()
    assert "islands" not in settings_record(eps, agent, NavMeshSettings(), {}, "val")["navmesh"]
    assert settings_record(eps, agent, NavMeshSettings(islands="all"), {}, "val")["navmesh"]["islands"] == "all"
    scene, _ = open_scene(str(house), {}, NavMeshSettings())
    assert build_key(scene, NavMeshSettings(islands="all")) == build_key(scene, NavMeshSettings())  # one navmesh
    from rvn_data.render import CameraConfig, RendererConfig
    from rvn_rl.depth.pairs import pair_meta

    pairs = ("train", [("procedural:train/0", 0)], 4, 0, CameraConfig(), RendererConfig())
    assert pair_meta(*pairs, NavMeshSettings()) == pair_meta(*pairs)  # the depth pairs' files made before: kept
    assert pair_meta(*pairs, NavMeshSettings(islands="all"))["navmesh_islands"] == ["all", 1.5]  # others: made anew
    wider = pair_meta(*pairs, NavMeshSettings(agent_radius=0.25))  # poses drawn on another navmesh: made anew
    assert wider["navmesh"]["agent_radius"] == 0.25 and "navmesh_islands" not in wider
    with pytest.raises(ValueError, match=r"navmesh setting islands='floors' must be one of \['main', 'all'\]"):
        NavMeshSettings(islands="floors")
    with pytest.raises(ValueError, match="min_island_radius=-1.0 must be >= 0"):
        NavMeshSettings(min_island_radius=-1)


def test_episodes_start_on_every_floor_with_goals_on_the_start_floor(house):
    settings = EpisodeSettings(d_min=2.0, d_max=5.0, n_goals=3)
    for islands, floors in (("main", {0}), ("all", {0, 1})):
        scene, nm = open_scene(str(house), {}, NavMeshSettings(islands=islands))
        eps = sample_episodes(nm, settings, "val", scene.scene_id, 0, range(24))
        assert {floor_of(e.start_position[1]) for e in eps} == floors, islands
        for e in eps:
            island = nm.island_of(e.start_position)
            assert set(nm.island_of(e.goals).tolist()) == {island}
            assert all(2.0 <= d <= 5.0 for d in e.goal_distances)


def test_rl_env_resets_on_both_floors_with_a_goal_pool(house, tmp_path):
    env = RVNEnv(mode="train", scene_specs=[str(house)], navmesh={"islands": "all"}, goal_pool=16,
                 episodes={"d_min": 2.0, "d_max": 5.0}, camera={"width": 32, "height": 24},
                 renderer={"backend": "raycast"}, cache_dir=str(tmp_path))
    try:
        seen = set()
        for i in range(16):
            env.reset(seed=3) if i == 0 else env.reset()
            seen.add(floor_of(env.position[1]))
            assert floor_of(env.goal[1]) == floor_of(env.position[1])
    finally:
        env.close()
    assert seen == {0, 1}
    _, nm = open_scene(str(house), {}, NavMeshSettings(islands="all"))
    assert {floor_of(g[1]) for g in GoalPool.build(nm, 16, 0, 0).goals} == {0, 1}  # the pool covers both floors


@pytest.mark.slow
def test_rvn_scene_rvn_gen_and_rvn_eval_on_both_floors(house, tmp_path):
    """rvn-scene says which islands are drawn on and what islands=all adds; rvn-gen's trajectories lie on both
    floors, each on one, with a map panel a floor; rvn-eval's episodes start on both."""
    env = {**os.environ, "RVN_CACHE_DIR": str(tmp_path / "cache")}
    info = subprocess.run([sys.executable, "-m", "rvn_data.cli.scene", "info", str(house)], capture_output=True,
                          text=True, timeout=300, env=env)
    assert info.returncode == 0, info.stderr
    assert "--islands all (navmesh.islands=all) adds island 1, of radius >= 1.5 m" in info.stdout
    info = subprocess.run([sys.executable, "-m", "rvn_data.cli.scene", "info", str(house), "--islands", "all", "--json"],
                          capture_output=True, text=True, timeout=300, env=env)
    assert json.loads(info.stdout)["sampled_islands"] == [0, 1] and json.loads(info.stdout)["narrow_islands"] == []
    assert json.loads(info.stdout)["floors"] == [0.0, UPPER_Y]
    ledge = tmp_path / "ledge.glb"  # a room with a 0.6 m thick, 8 m long block 2.2 m high: its top is a strip
    mesh = trimesh.util.concatenate([_box((10.0, 0.02, 6.0), (0, -0.01, 0)), *_walls(10.0, 6.0, 0.0, 2.8),
                                     _box((8.0, 2.2, 0.6), (0, 1.1, 0))])
    mesh.export(ledge)
    info = subprocess.run([sys.executable, "-m", "rvn_data.cli.scene", "info", str(ledge)], capture_output=True,
                          text=True, timeout=300, env=env)
    assert "(narrow: a ledge or wall top?)" in info.stdout and "would draw on narrow islands" in info.stdout, info.stdout

    out = tmp_path / "gen"

    def rvn_gen(*islands):
        return subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={out}", "scenes=mesh_dir",
                               f"scenes.root={house.parent}", "scenes.num_scenes=null", "dataset.d_min=2",
                               "dataset.d_max=6", "trajectories_per_scene=10", *islands, "camera.width=32",
                               "camera.height=32", "progress=false"], capture_output=True, text=True, timeout=600, env=env)
    gen = rvn_gen("navmesh.islands=all")
    assert gen.returncode == 0, gen.stderr[-3000:]
    main = rvn_gen()  # the dataset's settings differ: refused in one line naming them
    assert main.returncode == 2 and ("made with navmesh.islands='all' but this run uses navmesh.islands=its default "
                                     "(also navmesh.min_island_radius: 1.5 -> its default)") in main.stderr, main.stderr
    floors = []
    for traj in sorted(out.glob("house_expert_*")):
        meta = json.loads((traj / "rvn_meta.json").read_text())
        heights = {floor_of(p[1]) for p in (meta["start"], meta["goal"])}
        assert len(heights) == 1, traj  # start and goal on one floor
        floors.append(heights.pop())
        assert len(load_traj_data(traj)[0]) > 1
    assert set(floors) == {0, 1}, floors
    img = cv2.imread(str(out / "maps" / "house.png"))
    assert img.shape[1] > img.shape[0] * 2  # two floors side by side

    ev = subprocess.run([sys.executable, "-c", "from rvn_data.benchmark.cli import main; main()", "scenes=mesh_dir",
                         f"scenes.root={house.parent}", "policy=oracle", "split=val", "episodes.per_scene=8",
                         "episodes.n_goals=2", "episodes.d_min=2", "episodes.d_max=5", "navmesh.islands=all",
                         "camera.width=32", "camera.height=32", "progress=false", "paths=true", f"out_dir={tmp_path / 'eval'}"],
                        capture_output=True, text=True, timeout=600, env=env)
    assert ev.returncode == 0, ev.stderr[-3000:]
    records = [json.loads(line) for line in (tmp_path / "eval" / "episodes.jsonl").read_text().splitlines()]
    assert len(records) == 8 and json.loads((tmp_path / "eval" / "run.json").read_text())["navmesh"]["islands"] == "all"
    assert json.loads((tmp_path / "eval" / "metrics.json").read_text())["SR_1"] == 1.0
    [episode_file] = (tmp_path / "cache" / "episodes").rglob("*_house.json.gz")
    episodes = json.loads(gzip.decompress(episode_file.read_bytes()))["episodes"]
    assert {floor_of(e["start_position"][1]) for e in episodes} == {0, 1}
    img = cv2.imread(str(tmp_path / "eval" / "maps" / "house.png"))  # paths=true: a panel a floor
    assert img.shape[1] > img.shape[0] * 2


def test_episodes_and_rl_goals_stay_on_the_start_floor_of_an_island_with_stairs(mezzanine, tmp_path):
    """Stairs join the mezzanine to the floor below in one island: a benchmark episode's goals (23 of 72 before the
    rule) and an RL env's goals, from its pool (34 of 100 draws) or drawn fresh, lie within 0.5 m of the start's (the
    robot's) height, Habitat's PointNav rule."""
    scene, nm = open_scene(str(mezzanine), {}, NavMeshSettings())
    eps = sample_episodes(nm, EpisodeSettings(d_min=2.0, d_max=8.0, n_goals=6), "val", scene.scene_id, 0, range(12))
    assert {round(e.start_position[1], 1) for e in eps} == {0.0, 1.2}  # starts below and up on the mezzanine
    assert all(abs(g[1] - e.start_position[1]) <= 0.5 for e in eps for g in e.goals)
    for pool in (16, 0):
        env = RVNEnv(mode="train", scene_specs=[str(mezzanine)], goal_pool=pool, episodes={"d_min": 2.0, "d_max": 8.0},
                     camera={"width": 16, "height": 16}, renderer={"backend": "raycast"}, cache_dir=str(tmp_path))
        try:
            seen = set()
            for i in range(24):
                env.reset(seed=5) if i == 0 else env.reset()
                seen.add(round(float(env.position[1]), 1))
                assert abs(env.goal[1] - env.position[1]) <= 0.5, (pool, env.position, env.goal)
        finally:
            env.close()
        assert {0.0, 1.2} <= seen, pool  # and on the stairs


def test_maps_tell_the_floors_of_an_island_with_stairs_apart(mezzanine, house):
    """The maps' panels are floors, told apart by height: stairs join the mezzanine and the floor below into one
    island (and the navmesh's layers are not floors either), which drew both floors' paths on one panel."""
    _, nm = open_scene(str(mezzanine), {}, NavMeshSettings())
    floors = floor_heights(nm)
    assert [round(h, 2) for h in floors] == [0.0, 1.2]
    rng = np.random.default_rng(0)
    points = [nm.sample(rng) for _ in range(80)]
    groups = by_floor(nm, points)
    assert [round(h, 2) for h, _ in groups] == [0.0, 1.2] and sum(len(i) for _, i in groups) == 80
    for h, members in groups:
        assert all(abs(points[i][1] - h) == min(abs(points[i][1] - f) for f in floors) for i in members)
        panel = floor_grid(nm, h)
        assert np.nanmax(np.abs(panel.height[panel.free] - h)) <= 0.5
        centres = panel.grid_to_world(np.argwhere(panel.free))[::50]
        assert np.allclose(nm.floor_height(centres), centres[:, 1], atol=1e-6)  # the navmesh's own cells
    upper = floor_grid(nm, 1.2)
    assert 10 < upper.free.sum() * upper.cs ** 2 < 16  # the 3.5 x 4 m mezzanine and the stairs' top steps
    for islands, heights in (("main", [0.0]), ("all", [0.0, UPPER_Y])):  # floors of the sampled islands (a bed's not)
        _, nm = open_scene(str(house), {}, NavMeshSettings(islands=islands))
        assert [round(h, 2) for h in floor_heights(nm)] == heights


@pytest.mark.slow
def test_rvn_gen_keeps_goals_on_the_start_floor_of_an_island_with_stairs(mezzanine, tmp_path):
    """A goal up the stairs is on the start's island, but the expert plans on the start floor's grid: it was planned
    to the point beneath it (recorded with a goal 1.2 m above the path's end, e.g. a 2.2 m path for a 7.96 m geodesic
    distance); goals are now within 0.5 m of their start's height, as Habitat's PointNav generator keeps them."""
    scene = mezzanine
    _, nm = open_scene(str(scene), {}, NavMeshSettings())
    assert nm.num_islands == 1 and nm.island_shapes.heights[0] > 0.1  # both floors, one island
    out = tmp_path / "gen"
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={out}", "scenes=mesh_dir",
                           f"scenes.root={scene.parent}", "scenes.num_scenes=null", "dataset.d_min=2", "dataset.d_max=8",
                           "trajectories_per_scene=40", "camera.width=32", "camera.height=32", "progress=false"],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "RVN_CACHE_DIR": str(tmp_path / "cache")})
    assert proc.returncode == 0, proc.stderr[-3000:]
    metas = [json.loads(p.read_text()) for p in sorted(out.glob("mezzanine_expert_*/rvn_meta.json"))]
    assert len(metas) == 40
    assert {round(m["start"][1]) for m in metas} == {0, 1}  # starts below and up on the mezzanine
    assert all(abs(m["goal"][1] - m["start"][1]) <= 0.5 for m in metas)
    img = cv2.imread(str(out / "maps" / "mezzanine.png"))  # a panel a floor (was one, at the first start's floor)
    assert img.shape[1] > img.shape[0] * 3
