"""Episode sets: goal chains, determinism, reproducible files, settings checks."""
import gzip
import json
import shutil

import numpy as np
import pytest

from rvn_data.conventions import AgentConfig
from rvn_data.benchmark.episodes import (GENERATOR_VERSION, EpisodeSettings, episode_rng, sample_episode,
                                        sample_episodes, settings_record)
from rvn_data.benchmark.episodes_source import EnvConfig, ensure_scene_episodes
from rvn_data.navmesh.source import open_scene
from rvn_data.benchmark.episodes_store import EpisodeStore
from rvn_data.navmesh import NavMeshSettings
from rvn_data.scenes import Part, Scene, SceneError

SPEC = "procedural:val/0"
SETTINGS = EpisodeSettings(n_goals=6, seed=3)


@pytest.fixture(scope="module")
def loaded():
    return open_scene(SPEC, {}, NavMeshSettings())


@pytest.fixture(scope="module")
def navmesh(loaded):
    return loaded[1]


def store_for(root, settings=SETTINGS, agent=AgentConfig(), split="val"):
    nav = NavMeshSettings(agent_radius=agent.r_robot, agent_height=agent.h_robot)
    return EpisodeStore(root, split, settings_record(settings, agent, nav, {"source": "procedural"}, split))


def test_goal_chain_geodesic_range(navmesh):
    ep, fields = sample_episode(navmesh, SETTINGS, "val", SPEC, 0, 0)
    assert ep.goals.shape == (6, 3) and len(ep.goal_distances) == 6 and len(fields) == 6
    assert navmesh.island_of(ep.start_position) == 0
    prev = ep.start_position
    for goal, d in zip(ep.goals, ep.goal_distances):
        assert navmesh.island_of(goal) == 0
        assert 4.0 <= d <= 8.0
        # an independent measure of the same distance (string-pulled path) agrees within 5 %
        assert navmesh.geodesic_distance(prev, goal) == pytest.approx(d, rel=0.05)
        prev = goal
    assert -np.pi <= ep.start_yaw < np.pi


def test_episode_determinism(navmesh):
    a = sample_episodes(navmesh, SETTINGS, "val", SPEC, 0, range(3))
    b = sample_episodes(navmesh, SETTINGS, "val", SPEC, 0, [2])
    assert a[2].to_json() == b[0].to_json()  # episode e does not depend on how many were asked for
    assert a[0].to_json() != a[1].to_json()
    other_split = sample_episodes(navmesh, SETTINGS, "test", SPEC, 0, [0])[0]
    assert other_split.to_json() != a[0].to_json()
    r1, r2 = episode_rng(3, "val", 0, 1), episode_rng(3, "val", 0, 1)
    assert r1.integers(1 << 30) == r2.integers(1 << 30)


def test_store_bytes_reproducible_and_prefix(tmp_path, loaded):
    open_nm = lambda: loaded  # noqa: E731
    s1, s2 = store_for(tmp_path / "a"), store_for(tmp_path / "b")
    eps = s1.episodes_for(0, SPEC, 3, open_nm)
    s2.episodes_for(0, SPEC, 2, open_nm)
    s2.episodes_for(0, SPEC, 3, open_nm)  # extended from 2 to 3
    p1, p2 = s1.scene_path(0, SPEC), s2.scene_path(0, SPEC)
    assert p1.name == "00000_proc_val_0000.json.gz"  # the scene's slug, as rvn-gen names it
    assert p1.read_bytes() == p2.read_bytes()
    # another scene's file under the same index (the scene list changed) is not taken for this scene's
    other = p2.with_name("00000_proc_val_0007.json.gz")
    p2.rename(other)
    assert [e.to_json() for e in s2.episodes_for(0, SPEC, 3, open_nm)] == [e.to_json() for e in eps]
    assert p2.read_bytes() == p1.read_bytes() and other.is_file()
    assert p1.read_bytes()[4:8] == b"\0\0\0\0"  # gzip mtime 0
    s1.write_index()
    index = json.loads(s1.index_path.read_text())
    assert index["scenes"] == [{"file": p1.name, "scene_id": SPEC, "scene_index": 0, "episodes": 3,
                                "fingerprint": loaded[0].fingerprint()}]
    assert index["settings"]["episodes"]["n_goals"] == 6 and index["settings"]["generator_version"] == GENERATOR_VERSION
    data = json.loads(gzip.decompress(p1.read_bytes()))
    assert data["settings"]["agent"]["r_robot"] == 0.18 and data["settings"]["navmesh"]["cell_size"] == 0.05
    # fewer episodes are served from the file without regenerating (no navmesh needed)
    again = s1.episodes_for(0, SPEC, 2, lambda: pytest.fail("should not regenerate"))
    assert [e.to_json() for e in again] == [e.to_json() for e in eps[:2]]


def test_other_settings_get_their_own_folder(tmp_path, loaded):
    base = store_for(tmp_path)
    base.episodes_for(0, SPEC, 1, lambda: loaded)
    base.write_index()
    other = store_for(tmp_path, EpisodeSettings(n_goals=5, seed=3))
    bigger = store_for(tmp_path, agent=AgentConfig(r_robot=0.2))
    assert len({base.dir, other.dir, bigger.dir}) == 3 and base.dir.parent == tmp_path / "procedural"
    assert base.dir.name.startswith("val-") and store_for(tmp_path).dir == base.dir  # the key is stable
    assert len(other.episodes_for(0, SPEC, 1, lambda: loaded)[0].goals) == 5
    assert len(base.episodes_for(0, SPEC, 1, lambda: pytest.fail("regenerated"))[0].goals) == 6
    elsewhere = EpisodeStore(tmp_path, "val", base.settings, scenes_root=tmp_path / "meshes")
    assert elsewhere.dir != base.dir  # another scenes.root, another set


def test_file_with_other_settings_is_an_error(tmp_path, loaded):
    """A file copied by hand into another settings' folder is still refused, naming the setting."""
    base = store_for(tmp_path)
    base.episodes_for(0, SPEC, 1, lambda: loaded)
    base.write_index()
    other = store_for(tmp_path, EpisodeSettings(n_goals=5, seed=3))
    path = other.scene_path(0, SPEC)
    path.parent.mkdir(parents=True)
    shutil.copy(base.scene_path(0, SPEC), path)
    with pytest.raises(ValueError, match=rf"{path}.*episodes.n_goals=6.*episodes.n_goals=5"):
        other.episodes_for(0, SPEC, 1, lambda: loaded)
    bigger = store_for(tmp_path, agent=AgentConfig(r_robot=0.2))
    bigger.dir.mkdir(parents=True)
    shutil.copy(base.index_path, bigger.index_path)
    with pytest.raises(ValueError, match=r"index.json.*agent.r_robot=0.18.*agent.r_robot=0.2"):
        bigger.episodes_for(0, SPEC, 1, lambda: loaded)


def test_changed_scene_mesh_is_an_error(tmp_path, loaded):
    scene, navmesh = loaded
    store = store_for(tmp_path)
    store.episodes_for(0, SPEC, 1, lambda: loaded)
    assert store.episodes_for(0, SPEC, 1, None, loaded=loaded)  # same mesh: fine
    parts = [Part(p.name, p.vertices + np.float32(0.01), p.faces) for p in scene.parts]
    moved = Scene(scene.scene_id, parts, scene.source)
    with pytest.raises(ValueError, match=r"00000_proc_val_0000.json.gz.*another version of scene"):
        store.episodes_for(0, SPEC, 1, None, loaded=(moved, navmesh))


def test_env_config_caches_episodes(tmp_path):
    cfg = EnvConfig.from_kwargs(mode="eval", split="val", scenes={"num_scenes": 1}, per_scene=2,
                                episodes={"n_goals": 3, "dir": str(tmp_path)})
    assert cfg.scene_slots() == [(SPEC, 0)]
    assert ensure_scene_episodes(cfg, (SPEC, 0)) == 2
    assert [p.relative_to(tmp_path).parts[::2] for p in tmp_path.rglob("*.json.gz")] == \
        [("procedural", "00000_proc_val_0000.json.gz")]
    assert cfg.store().scene_path(0, SPEC).exists()


def test_scene_too_small_is_named(navmesh):
    far = EpisodeSettings(d_min=60.0, d_max=80.0, n_goals=2, max_tries=20, max_restarts=2)
    with pytest.raises(SceneError, match=r"procedural:val/0.*d_min"):
        sample_episode(navmesh, far, "val", SPEC, 0, 0)


def test_bad_settings():
    with pytest.raises(ValueError, match="d_min"):
        EpisodeSettings(d_min=8.0, d_max=4.0)
    with pytest.raises(ValueError, match="n_goals"):
        EpisodeSettings(n_goals=0)
    with pytest.raises(ValueError, match="unknown split"):
        episode_rng(0, "holdout", 0, 0)
