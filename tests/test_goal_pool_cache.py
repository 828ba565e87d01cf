"""Train-mode goal pools kept under the cache root (rvn_data/benchmark/pool_cache.py): a pool read back equals the
built one and gives the same goal draws, a file belongs to one navmesh and one pool, bad files are rebuilt, and a
train-mode env reads its scenes' pools back instead of solving them again, with the same episodes."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from rvn_data.benchmark import goal_pool
from rvn_data.benchmark.env import RVNEnv
from rvn_data.benchmark.goal_pool import GoalPool, PoolSampler
from rvn_data.navmesh import NavMeshSettings
from rvn_data.navmesh.field_sets import FieldTrees
from rvn_data.navmesh.source import open_scene

STATE = ("goals", "roots", "pred", "gk", "gi", "gj", "values")  # values: smoothed whole, bit for bit


def assert_same(a: GoalPool, b: GoalPool) -> None:
    for k in STATE:
        x, y = getattr(a.stack, k), getattr(b.stack, k)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), k
    assert a.stack.smoothed and b.stack.smoothed and len(a.stack.trees) == len(b.stack.trees)
    assert np.array_equal(np.isfinite(a.stack.out), np.isfinite(b.stack.out))  # done where reached: no read smooths


def files(folder):
    return sorted(folder.glob("*.npz"))


def no_solves(monkeypatch):
    def fail(*args, **kwargs):
        pytest.fail("a goal pool was solved although it was kept")
    monkeypatch.setattr(FieldTrees, "__init__", fail)


@pytest.fixture(scope="module")
def navmesh():
    return open_scene("procedural:val/0", {}, NavMeshSettings())[1]


def test_a_kept_pool_is_the_built_one(navmesh, tmp_path, monkeypatch):
    built = GoalPool.build(navmesh, 16, 2, 0, tmp_path)  # a miss: solved, then written
    assert len(files(tmp_path)) == 1 and files(tmp_path)[0].name.startswith("procedural_val_0-")
    assert not list(tmp_path.glob(".*"))  # no temporary file left
    plain = GoalPool.build(navmesh, 16, 2, 0)
    assert_same(built, plain)
    with monkeypatch.context() as m:
        no_solves(m)
        kept = GoalPool.build(navmesh, 16, 2, 0, tmp_path)
    assert_same(kept, plain)
    assert (plain.stack.pred == -9999).sum() == 16  # scipy's mark of a root survives the offsets
    rng = np.random.default_rng(0)
    starts = [navmesh.sample(rng, island=0) for _ in range(30)]
    a, b = PoolSampler(navmesh, kept), PoolSampler(navmesh, plain)
    for p in starts:
        da, db = a.sample(p, np.random.default_rng(5), 3.0, 8.0), b.sample(p, np.random.default_rng(5), 3.0, 8.0)
        assert (da is None) == (db is None)
        if da is not None:
            assert np.array_equal(da[0], db[0]) and da[1].distance(p) == db[1].distance(p)
    assert sum(a.sample(p, rng, 3.0, 8.0) is not None for p in starts) > 10


def test_a_file_holds_one_navmesh_and_one_pool(navmesh, tmp_path):
    GoalPool.build(navmesh, 8, 2, 0, tmp_path)
    GoalPool.build(navmesh, 8, 2, 0, tmp_path)
    assert len(files(tmp_path)) == 1
    for size, split_code, index in ((9, 2, 0), (8, 1, 0), (8, 2, 1)):  # the pool's size and its goals' seed
        GoalPool.build(navmesh, size, split_code, index, tmp_path)
    assert len(files(tmp_path)) == 4
    wider = open_scene("procedural:val/0", {}, NavMeshSettings(agent_radius=0.25))[1]
    assert_same(GoalPool.build(wider, 8, 2, 0, tmp_path), GoalPool.build(wider, 8, 2, 0))
    assert len(files(tmp_path)) == 5


def test_an_unreadable_file_is_rebuilt_and_an_unwritable_folder_only_warned_about(navmesh, tmp_path):
    plain = GoalPool.build(navmesh, 8, 2, 0)
    GoalPool.build(navmesh, 8, 2, 0, tmp_path)
    path = files(tmp_path)[0]
    path.write_bytes(path.read_bytes()[:1000])  # cut short, as by a full disk
    with pytest.warns(UserWarning, match=rf"goal pool cache file {path} is unreadable .*rebuilding it"):
        assert_same(GoalPool.build(navmesh, 8, 2, 0, tmp_path), plain)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert_same(GoalPool.build(navmesh, 8, 2, 0, tmp_path), plain)  # replaced by a whole file
    data = bytearray(path.read_bytes())
    for k in range(len(data) // 3, len(data) // 3 + 64):
        data[k] ^= 0xFF  # bytes flipped inside the compressed arrays
    path.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match=rf"goal pool cache file {path} is unreadable"):
        assert_same(GoalPool.build(navmesh, 8, 2, 0, tmp_path), plain)
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the folder would go")
    with pytest.warns(UserWarning, match=r"cannot keep goal pools in .*blocked.*RVN_CACHE_DIR"):
        assert_same(GoalPool.build(navmesh, 8, 2, 0, blocked), plain)


def test_a_train_env_reads_its_pools_back_with_the_same_episodes(tmp_path, monkeypatch):
    """Two runs of a train-mode env over the same cache root: the second reads every scene's pool from
    ``<root>/goal_pools`` (no Dijkstra solve of a pool), with the same starts, goals and observations."""
    kw = dict(mode="train", split="val", scenes={"num_scenes": 3}, scene_switch_every=1, goal_pool=12,
              camera={"width": 32, "height": 24}, renderer={"backend": "raycast"}, cache_dir=str(tmp_path))

    def run():
        goal_pool._POOLS.clear()  # the process's own cache: a new run starts without it
        env, out = RVNEnv(**kw), []
        try:
            for i in range(6):
                obs, info = env.reset(seed=11) if i == 0 else env.reset()
                out.append((info["scene_id"], env.position.copy(), env.goal.copy(), obs["rgb"].copy()))
        finally:
            env.close()
        return out

    first = run()
    kept = files(tmp_path / "goal_pools")
    assert len({s for s, *_ in first}) > 1 and len(kept) == len({s for s, *_ in first})
    with monkeypatch.context() as m:
        no_solves(m)
        second = run()
    assert files(tmp_path / "goal_pools") == kept
    for (sa, pa, ga, oa), (sb, pb, gb, ob) in zip(first, second):
        assert sa == sb and np.array_equal(pa, pb) and np.array_equal(ga, gb) and np.array_equal(oa, ob)
