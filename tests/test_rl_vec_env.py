"""`BatchEnv`'s same-step autoreset and `RolloutStorage`'s GAE: a finished episode's last
transition keeps its own reward and done flag, the returned observation is the next
episode's first, and returns do not bootstrap across the episode boundary."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from rvn_data.conventions import Action, relative_goal
from rvn_rl.rollout import RolloutStorage
from rvn_rl.vec_env import BatchEnv, CachedSceneEnv, env_seed

from render_helpers import needs_egl

KW = dict(mode="train", split="train", scenes={"num_scenes": 2}, camera={"width": 32, "height": 32},
          renderer={"backend": "raycast"}, episodes={"n_goals": 2})


@pytest.mark.slow
def test_autoreset_gives_the_next_episodes_first_observation():
    envs = BatchEnv(KW, 2, seed=3)
    try:
        obs = envs.reset()
        ended, returns = 0, np.zeros(2)
        for _ in range(200):  # always forward: episodes end by collisions
            obs, reward, cost, done, infos = envs.step(np.full(2, int(Action.MOVE_FORWARD)))
            returns += reward
            for i, env in enumerate(envs.envs):
                # the returned observation is always the env's current state (after a reset when done)
                np.testing.assert_allclose(obs["pointgoal"][i], relative_goal(env.position, env.yaw, env.goal),
                                           atol=1e-5)
                if done[i]:
                    ep = infos[i]["episode"]
                    assert env.episode_record()["steps"] == 0  # a fresh episode
                    assert ep["termination"] in ("collision", "timeout", "success")
                    if ep["termination"] == "collision":
                        assert reward[i] == np.float32(-0.1) and cost[i] == 1.0
                    assert abs(ep["return"] - returns[i]) < 1e-4
                    returns[i] = 0.0
                    ended += 1
                else:
                    assert "episode" not in infos[i]
        assert ended >= 2
    finally:
        envs.close()


@needs_egl
def test_batched_observations_equal_each_envs_own_and_take_one_render_pass(monkeypatch):
    """The envs' frames rendered together (gl: one pass per step for envs in different scenes)
    equal each env stepped alone with its own render() per step, autoresets and scene switches included."""
    from rvn_data.render import gl

    kw = {**KW, "scenes": {"num_scenes": 3}, "renderer": {"backend": "gl"}, "depth": True, "scene_switch_every": 1}
    passes = []
    real_pass = gl.GLRenderer._render_pass
    monkeypatch.setattr(gl.GLRenderer, "_render_pass",
                        lambda self, views, rgb, depth: (passes.append(len(views)), real_pass(self, views, rgb, depth)))
    envs, alone = BatchEnv(kw, 3, seed=5), [CachedSceneEnv(**kw) for _ in range(3)]
    try:
        obs = envs.reset()
        want = [env.reset(seed=env_seed(5, 0, i))[0] for i, env in enumerate(alone)]
        assert passes == [3]
        rng, ended, mixed = np.random.default_rng(0), 0, 0
        for _ in range(40):
            actions = rng.choice([0, 1, 1, 1, 2, 3], size=3)  # mostly forward: episodes end by collisions
            for i, env in enumerate(alone):
                np.testing.assert_array_equal(obs["rgb"][i], want[i]["rgb"])
                np.testing.assert_array_equal(obs["depth"][i], want[i]["depth"])
                np.testing.assert_array_equal(obs["pointgoal"][i], want[i]["pointgoal"])
            passes.clear()
            obs, reward, _, done, infos = envs.step(actions)
            assert passes == [3]
            mixed += len({env.view()[0].scene.scene_id for env in envs.envs}) > 1
            for i, env in enumerate(alone):
                want[i], r, terminated, truncated, info = env.step(int(actions[i]))
                assert reward[i] == np.float32(r) and done[i] == (terminated or truncated)
                if done[i]:
                    assert infos[i]["episode"]["steps"] == info["episode"]["steps"]
                    want[i] = env.reset()[0]
                    ended += 1
        assert ended >= 2 and mixed >= 5  # frames of different scenes in one pass
    finally:
        envs.close()
        for env in alone:
            env.close()


@pytest.mark.slow
def test_worker_processes_pass_the_same_observations_through_shared_memory():
    """`ProcessBatchEnv` (2 workers, frames through shared memory) returns what `BatchEnv` does in one
    process, step by step; a returned batch stays as it was after later steps; closing unlinks the blocks."""
    from multiprocessing import shared_memory

    from rvn_rl.vec_procs import ProcessBatchEnv

    kw = {**KW, "depth": True}
    alone, procs = BatchEnv(kw, 3, seed=7), ProcessBatchEnv(kw, 3, workers=2, seed=7)
    try:
        rng, kept = np.random.default_rng(1), []
        pairs = [(alone.reset(), procs.reset())]
        for _ in range(30):
            actions = rng.choice([0, 1, 1, 1, 2, 3], size=3)
            a, b = alone.step(actions), procs.step(actions)
            for x, y in zip(a[1:4], b[1:4]):
                np.testing.assert_array_equal(x, y)
            assert [i.get("episode") for i in a[4]] == [i.get("episode") for i in b[4]]
            pairs.append((a[0], b[0]))
            kept.append({k: v.copy() for k, v in b[0].items()})
        for (want, got), copy in zip(pairs, [None] + kept):
            assert set(want) == set(got) == {"rgb", "pointgoal", "depth"}
            for key in want:
                np.testing.assert_array_equal(got[key], want[key])
                if copy is not None:
                    np.testing.assert_array_equal(got[key], copy[key])  # not overwritten by later steps
        names = [block.name for blocks in procs.blocks for block in blocks.blocks]
        assert len(names) == 6  # rgb, pointgoal, depth of each worker
    finally:
        alone.close()
        procs.close()
    for name in names:
        with pytest.raises(FileNotFoundError):
            shared_memory.SharedMemory(name=name)


EVERY_RESET, BY_STEPS = {"scene_switch_every": 1}, {"scene_switch_every": 0, "scene_switch_steps": 4}


@pytest.mark.parametrize("backend, switch", [("raycast", EVERY_RESET), ("raycast", BY_STEPS),
                                             pytest.param("gl", EVERY_RESET, marks=needs_egl)])
def test_prefetched_scenes_give_the_same_episodes(monkeypatch, backend, switch):
    """With env.prefetch_scenes each env draws its next scene ahead and has it prepared while it steps (scene, navmesh
    and goal pool made in a helper process, with the GL renderer's mesh arrays under gl, the simulator in a thread):
    observations, rewards, episode records and scene order equal the envs' without it, across scene switches at every
    reset (or after a visit's budget of steps, env.scene_switch_steps) and a reset with a seed, which starts the scene
    stream again. A pool this process keeps is not made again."""
    import threading

    from rvn_data.helper_process import HelperProcess

    import rvn_data.render as render

    made, real_make = [], render.make_renderer  # whether each renderer came with mesh arrays made ahead
    monkeypatch.setattr(render, "make_renderer", lambda *a, gl_arrays=None, **k: (
        made.append(gl_arrays is not None), real_make(*a, gl_arrays=gl_arrays, **k))[1])
    threads, calls = [], []
    real_call = HelperProcess.call
    monkeypatch.setattr(HelperProcess, "call", lambda self, fn, *a: (
        threads.append(threading.current_thread().name), calls.append((self, a[-1])), real_call(self, fn, *a))[2])
    kw = {**KW, "scenes": {"num_scenes": 6}, **switch, "goal_pool": 8, "renderer": {"backend": backend}}
    plain, ahead = BatchEnv(kw, 2, seed=7, prefetch=False), BatchEnv(kw, 2, seed=7)
    try:
        a, b = plain.reset(), ahead.reset()
        rng, ended, scenes = np.random.default_rng(2), 0, []
        for t in range(100):
            for key in a:
                np.testing.assert_array_equal(b[key], a[key], err_msg=f"{key} at step {t}")
            if t == 50:  # a reset with the seeds: the scenes drawn ahead are not next any more
                a, b = plain.reset(), ahead.reset()
                continue
            actions = rng.choice([0, 0, 1, 1, 2], size=2)  # STOPs and collisions end episodes often
            ra, rb = plain.step(actions), ahead.step(actions)
            for x, y in zip(ra[1:4], rb[1:4]):
                np.testing.assert_array_equal(y, x)
            assert [i.get("episode") for i in rb[4]] == [i.get("episode") for i in ra[4]]
            ended += int(ra[3].sum())
            scenes.append([env.scene.scene_id for env in ahead.envs])
            assert scenes[-1] == [env.scene.scene_id for env in plain.envs]
            a, b = ra[0], rb[0]
        assert ended >= 6 and len({s for pair in scenes for s in pair}) >= 3
        assert sum(env.prefetched for env in ahead.envs) >= 4 and sum(env.prefetched for env in plain.envs) == 0
        assert calls and all(name.startswith("rvn-scene-prefetch") for name in threads)
        assert (sum(made) >= 4) == (backend == "gl") and not all(made)  # the plain envs make their own
        helpers = [helper._proc for helper in {helper for helper, _ in calls}]
    finally:
        plain.close()
        ahead.close()
    assert all(env._threads is None and env._helper is None for env in ahead.envs)
    assert all(proc.poll() is not None for proc in helpers)  # closed with their envs


def test_a_prepared_scene_takes_the_pool_this_process_keeps(tmp_path, monkeypatch):
    """`CachedSceneEnv._prepare` has its helper process make a scene's goal pool only when this process keeps none:
    the same pool either way (its goals and draws), kept by the process after. Its navmesh comes with its geodesic
    graph built either way (the first goal draw's, which the env's own thread had built when the pool was kept)."""
    from rvn_data.benchmark.episodes_source import pool_key
    from rvn_data.benchmark.goal_pool import cached_pool
    from rvn_data.helper_process import HelperProcess

    env = CachedSceneEnv(**{**KW, "scenes": {"num_scenes": 3}, "goal_pool": 4, "cache_dir": str(tmp_path)})
    sent, real_call = [], HelperProcess.call
    monkeypatch.setattr(HelperProcess, "call", lambda self, fn, *a: (sent.append(a[-1]), real_call(self, fn, *a))[1])
    try:
        env.reset(seed=3)
        pos = next(p for p in range(3) if cached_pool(pool_key(env.config, env._slots[p])) is None)
        made = env._prepare(pos)  # in this thread: what the prefetch thread runs
        kept = cached_pool(pool_key(env.config, env._slots[pos]))
        again = env._prepare(pos)
        assert sent[-2:] == [True, False] and kept is not None
        assert made.navmesh._graph is not None and again.navmesh._graph is not None
        assert again.goal_sampler(env.config).stack is kept.stack is made.goal_sampler(env.config).stack
        rng = np.random.default_rng(0)
        start = made.navmesh.sample(rng, island=0)
        a = made.goal_sampler(env.config).sample(start, np.random.default_rng(1), 0.0, np.inf)
        b = again.goal_sampler(env.config).sample(start, np.random.default_rng(1), 0.0, np.inf)
        assert np.array_equal(a[0], b[0]) and a[1].distance(start) == b[1].distance(start)
    finally:
        env.close()


def test_gae_stops_at_episode_ends():
    T, N, gamma, tau = 5, 2, 0.9, 0.8
    st = RolloutStorage(T, N, {"pointgoal": ((2,), torch.float32)}, (4, N, 8), heads=1)
    st.set_first({"pointgoal": np.zeros((N, 2), np.float32)}, torch.zeros(4, N, 8), torch.zeros(N, dtype=torch.long),
                 torch.zeros(N))
    rng = np.random.default_rng(0)
    rewards, values = rng.normal(size=(T, N)), rng.normal(size=(T + 1, N))
    done = np.zeros((T, N), bool)
    done[2, 0] = True
    for t in range(T):
        st.insert({"pointgoal": np.zeros((N, 2), np.float32)}, torch.ones(N, dtype=torch.long), torch.zeros(N),
                  torch.tensor(values[t, :, None], dtype=torch.float32), rewards[t, :, None], done[t])
    adv = st.compute_returns(torch.tensor(values[T, :, None], dtype=torch.float32), gamma, tau)[..., 0].numpy()
    expect = np.zeros((T, N))
    for i in range(N):
        g = 0.0
        for t in reversed(range(T)):
            m = 0.0 if done[t, i] else 1.0
            delta = rewards[t, i] + gamma * values[t + 1, i] * m - values[t, i]
            g = delta + gamma * tau * m * g
            expect[t, i] = g
    np.testing.assert_allclose(adv, expect, rtol=1e-5, atol=1e-5)
    assert st.masks[3, 0] == 0 and st.masks[3, 1] == 1  # the step after the end starts a new episode
    assert np.isclose(adv[2, 0], rewards[2, 0] - values[2, 0], atol=1e-5)  # no bootstrap across the end


def test_device_rollouts_give_each_envs_whole_rollout_and_load_once_an_update():
    """The PPO update's mini-batches (`DeviceRollouts`): each the filled steps of a random subset of envs, every
    stored field of the same envs (frames, state, actions, masks, ...), flat time-major; the subsets of one epoch
    cover every env once; the rollout moves to the device once an update and again for the next one."""
    from rvn_rl.rollout import DeviceRollouts

    T, N, heads, steps = 6, 4, 2, 5  # a rollout that ended early (DD-PPO's pre-emption): 5 of 6 steps filled
    rng = np.random.default_rng(0)
    space = {"rgb": ((3, 3, 3), torch.uint8), "pointgoal": ((2,), torch.float32)}

    def obs() -> dict:
        return {"rgb": rng.integers(0, 256, (N, 3, 3, 3), dtype=np.uint8), "pointgoal": rng.normal(size=(N, 2)).astype(np.float32)}

    st = RolloutStorage(T, N, space, (4, N, 8), heads)
    batches = DeviceRollouts(st, "cpu")
    for update in range(2):
        st.set_first(obs(), torch.randn(4, N, 8), torch.randint(0, 4, (N,)), torch.ones(N))
        for _ in range(steps):
            st.insert(obs(), torch.randint(0, 4, (N,)), torch.randn(N), torch.randn(N, heads), rng.normal(size=(N, heads)),
                      rng.random(N) < 0.3)
        adv = st.compute_returns(torch.randn(N, heads), 0.99, 0.95)[..., 0]
        gen = torch.Generator().manual_seed(update)
        for _ in range(2):  # two epochs of one update: their draws differ, the rollout is loaded once
            seen = []
            for mb in batches.minibatches(adv, 2, gen):
                envs = [int(torch.nonzero((st.state0[0, :, 0] == s)).item()) for s in mb["state"][0, :, 0]]
                seen += envs
                k = len(envs)
                assert mb["obs"]["rgb"].shape == (steps * k, 3, 3, 3)
                for name, full in (("rgb", st.obs["rgb"]), ("pointgoal", st.obs["pointgoal"])):
                    assert torch.equal(mb["obs"][name], full[:steps, envs].reshape(steps * k, *full.shape[2:]))
                for name in ("prev_actions", "masks", "actions", "logp", "values", "returns"):
                    full = getattr(st, name)
                    assert torch.equal(mb[name], full[:steps, envs].reshape(steps * k, *full.shape[2:])), name
                assert torch.equal(mb["advantages"], adv[:, envs].reshape(-1))
                assert torch.equal(mb["state"], st.state0[:, envs])
            assert sorted(seen) == list(range(N))
        loaded = batches._on_device
        list(batches.minibatches(adv, 2, gen))
        assert batches._on_device is loaded  # the same update: not loaded again
        st.after_update(torch.randn(4, N, 8))
