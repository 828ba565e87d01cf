"""GNM reading, the packed HDF5 cache and the sample dict (issue 6, data part)."""
from __future__ import annotations

import math
import os
import pickle

import cv2
import numpy as np
import pytest
import torch

from rvn_il.data import EpochSampler, load_gnm, make_dataset
from rvn_il.data.cache import PackedCache, ensure_cache
from rvn_data.dataset.reader import read_spacing
from rvn_il.data.synthetic import write_synthetic_gnm
from rvn_il.models import load_model_config

torch.set_num_threads(1)

# actions of the hand-made trajectory: F forward 0.25 m, L/R turn 30 degrees
ACTIONS = "FFFLFFRRFFFFLLFF"


def hand_trajectory(x0=1.0, y0=2.0, yaw0=math.pi / 2):
    pos, yaw = [np.array([x0, y0])], [yaw0]
    for a in ACTIONS:
        p, y = pos[-1], yaw[-1]
        if a == "F":
            pos.append(p + 0.25 * np.array([math.cos(y), math.sin(y)]))
            yaw.append(y)
        else:
            pos.append(p.copy())
            yaw.append(y + (math.radians(30) if a == "L" else -math.radians(30)))
    return np.array(pos), np.array(yaw)


def write_traj(folder, position, yaw, size=32, seed=0):
    folder.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    for t in range(len(position)):
        cv2.imwrite(str(folder / f"{t}.jpg"), rng.integers(0, 255, (size, size, 3), dtype=np.uint8))
    with open(folder / "traj_data.pkl", "wb") as f:
        pickle.dump({"position": position, "yaw": yaw}, f)


def nomad_small(**kw):
    return load_model_config("nomad_pointgoal", "small", **kw)


def test_sample_dict_matches_hand_computed_waypoints(tmp_path):
    position, yaw = hand_trajectory()
    write_traj(tmp_path / "ds" / "a", position, yaw)
    cfg = nomad_small(context_size=2, len_traj_pred=4, goal_mask_prob=0.0, image_size=[16, 16])
    ds = make_dataset(tmp_path / "ds", cfg, {"goal_offset": [3, 3], "progress": False}, seed=0)
    # current frames t = 2 .. 17-1-3 = 13
    assert len(ds) == 12
    s = ds[0]  # t = 2: pose (1, 2.5), yaw 90 deg; then F (t3), L (t4), F, F
    assert s["obs_image"].shape == (3, 3, 16, 16) and s["obs_image"].dtype == torch.uint8
    c, h = math.cos(math.radians(30)), math.sin(math.radians(30))
    expected = [[1, 0], [1, 0], [1 + c, h], [1 + 2 * c, 2 * h]]  # units of spacing = 0.25 m
    np.testing.assert_allclose(s["actions"].numpy(), expected, atol=1e-5)
    np.testing.assert_allclose(s["goal_pos"].numpy(), expected[2], atol=1e-5)  # goal = frame t+3
    assert int(s["distance"]) == 3 and float(s["goal_mask"]) == 0.0 and float(s["action_mask"]) == 1.0
    # oldest context frame first: frame t-2 = 0.jpg
    cache = PackedCache(ds.cache.path)
    torch.testing.assert_close(s["obs_image"][0], torch.from_numpy(np.array(cache.images[0])))
    # near the end the future is padded with the last pose (t = 13 -> frames 14..16, then 16 again)
    last = ds[len(ds) - 1]["actions"].numpy()
    np.testing.assert_allclose(last[3], last[2])
    assert not np.allclose(last[1], last[2]) or not np.allclose(last[0], last[1])


def test_moving_waypoints_skip_turns_in_place(tmp_path):
    position, yaw = hand_trajectory()
    write_traj(tmp_path / "ds" / "a", position, yaw)
    write_traj(tmp_path / "ds" / "b", position + 5, yaw)  # starts elsewhere: a seam in the cache after a's end
    cfg = nomad_small(context_size=2, len_traj_pred=4, goal_mask_prob=0.0, image_size=[16, 16])
    data = {"goal_offset": [3, 3], "progress": False}
    gnm = make_dataset(tmp_path / "ds", cfg, data, seed=0)
    ds = make_dataset(tmp_path / "ds", cfg, {**data, "waypoint_frames": "moving"}, seed=0)
    c, h = math.cos(math.radians(30)), math.sin(math.radians(30))
    # t = 2: F (frame 3), L (4, no move), F (5), F (6), R, R (7, 8, no move), F (9)
    np.testing.assert_allclose(ds[0]["actions"].numpy(), [[1, 0], [1 + c, h], [1 + 2 * c, 2 * h], [1 + 3 * c, h]],
                               atol=1e-5)
    # t = 6 (next: R, R, F, F, F, F): the first label is where the robot moves next, turns or not
    moving, frames = ds[4]["actions"].numpy(), gnm[4]["actions"].numpy()
    np.testing.assert_allclose(frames[:2], 0, atol=1e-9)  # GNM's: two waypoints on the spot
    np.testing.assert_allclose(moving[0], frames[2], atol=1e-9)
    assert np.all(np.linalg.norm(np.diff(moving, axis=0, prepend=0 * moving[:1]), axis=1) > 0.99)  # d_step apart
    # the rest of the sample is unchanged: same images, goal, distance
    for k in ("obs_image", "goal_pos", "distance"):
        assert torch.equal(ds[4][k], gnm[4][k]), k
    # t = 13 (L, F, F to the end at frame 16): padded with a's last pose, not b's first; same at b's end
    for last in (11, len(ds) - 1):
        np.testing.assert_allclose(ds[last]["actions"].numpy(), [[c, h]] + [[2 * c, 2 * h]] * 3, atol=1e-5)
    with pytest.raises(ValueError, match="data.waypoint_frames='every'.*all.*moving"):
        make_dataset(tmp_path / "ds", cfg, {**data, "waypoint_frames": "every"})


def test_pad_context_trains_the_first_decisions_with_frame_0_repeated(tmp_path):
    position, yaw = hand_trajectory()
    write_traj(tmp_path / "ds" / "a", position, yaw)
    write_traj(tmp_path / "ds" / "b", position + 5, yaw, seed=1)  # b's first context must not reach into a's frames
    cfg = nomad_small(context_size=2, len_traj_pred=4, goal_mask_prob=0.0, image_size=[16, 16])
    data = {"goal_offset": [3, 3], "progress": False}
    gnm = make_dataset(tmp_path / "ds", cfg, data, seed=0)
    ds = make_dataset(tmp_path / "ds", cfg, {**data, "pad_context": True}, seed=0)
    assert len(ds) == len(gnm) + 2 * 2  # t = 0 and 1 of each trajectory
    images = torch.from_numpy(np.array(PackedCache(ds.cache.path).images))
    b0 = len(position)  # global index of b's frame 0
    for i, (context, start) in enumerate([([0, 0, 0], 0), ([0, 0, 1], 0), ([b0, b0, b0], b0), ([b0, b0, b0 + 1], b0)]):
        item = ds[[0, 1, 14, 15][i]]
        torch.testing.assert_close(item["obs_image"], images[context])
        assert int(item["distance"]) == 3
    # t = 0 of a: the labels are frames 1..4 (F, F, F, L) in pose 0's frame, the goal frame 3
    np.testing.assert_allclose(ds[0]["actions"].numpy(), [[1, 0], [2, 0], [3, 0], [3, 0]], atol=1e-5)
    np.testing.assert_allclose(ds[0]["goal_pos"].numpy(), [3, 0], atol=1e-5)
    for k, v in gnm[0].items():  # from t = context_size on, the samples are GNM's
        torch.testing.assert_close(ds[2][k], v)
    with pytest.raises(ValueError, match="fewer than 1\\+goal_offset\\[0\\]\\+end_slack = 21"):
        make_dataset(tmp_path / "ds", cfg, {**data, "pad_context": True, "goal_offset": [20, 20]})


def test_goal_mask_probability_and_determinism(tmp_path):
    root = write_synthetic_gnm(tmp_path / "ds", 3, 30, image_size=32)
    ds = make_dataset(root, nomad_small(), {"progress": False}, seed=3)
    masks = ds.get_batch(range(len(ds) * 4))["goal_mask"].numpy()
    assert 0.35 < masks.mean() < 0.65
    a, b = ds.get_batch([5, 7, 5 + len(ds)]), ds.get_batch([5, 7, 5 + len(ds)])
    for k in a:
        assert torch.equal(a[k], b[k])
    single = ds[7]
    for k in single:
        assert torch.equal(single[k], a[k][1]), k
    goals = ds.get_batch(range(len(ds)))["distance"].numpy()
    assert goals.min() >= 1 and goals.max() <= 20
    vint = make_dataset(root, load_model_config("vint_pointgoal", "small"), {"progress": False})
    s = vint[0]
    assert s["obs_image"].shape[0] == 6 and s["actions"].shape == (5, 2) and float(s["goal_mask"]) == 0.0


def test_third_party_pickles_splits_and_spacing(tmp_path):
    position, yaw = hand_trajectory()
    root = tmp_path / "go_stanford"
    write_traj(root / "t0", position.astype(np.float32), yaw[:, None].astype(np.float32))  # [T,1] yaw
    write_traj(root / "t1", position + 5, yaw)
    write_traj(root / "t2", position - 5, yaw)
    (root / "data_config.yaml").write_text("go_stanford:\n  metric_waypoint_spacing: 0.12\naction_stats: {}\n")
    src = load_gnm(root)
    assert src.names == ["t0", "t1", "t2"] and src.spacing == 0.12
    assert src.positions[0].dtype == np.float64 and src.yaws[0].shape == (len(position),)
    split = root / "data_splits" / "go_stanford" / "test"
    split.mkdir(parents=True)
    (split / "traj_names.txt").write_text("t2\n\nt1\n")
    assert load_gnm(root, "test").names == ["t2", "t1"]
    assert read_spacing(root, "go_stanford", 0.3) == 0.3
    # a split the dataset's split files do not hold is refused: every folder would hold the test split's too
    with pytest.raises(ValueError, match=r"data_splits/go_stanford/train/traj_names.txt does not exist; .* holds "
                                         r"go_stanford/test/traj_names.txt: name one of them"):
        load_gnm(root, "train")
    assert load_gnm(root, "all").names == ["t0", "t1", "t2"]


def test_cache_rebuilt_when_source_changes(tmp_path):
    root = write_synthetic_gnm(tmp_path / "ds", 2, 12, image_size=32)
    size, cache = (16, 16), tmp_path / "cache"
    path = ensure_cache(load_gnm(root), size, cache_dir=cache, progress=False)
    assert path.is_relative_to(cache) and not list(root.rglob("*.h5"))  # the dataset is only read
    mtime = path.stat().st_mtime_ns
    assert ensure_cache(load_gnm(root), size, cache_dir=cache, progress=False).stat().st_mtime_ns == mtime  # reused
    frame = root / "traj_000_0000" / "3.jpg"
    cv2.imwrite(str(frame), np.full((32, 32, 3), 255, np.uint8))
    os.utime(frame, ns=(mtime + 10**9, mtime + 10**9))
    path2 = ensure_cache(load_gnm(root), size, cache_dir=cache, progress=False)
    assert path2 == path and path2.stat().st_mtime_ns != mtime
    assert np.asarray(PackedCache(path2).images[3]).min() > 240  # the new white frame is in the cache
    assert not list(path.parent.glob("*.tmp*"))  # no temporary file left (rvn_data.atomic: .<name>.*.tmp<suffix>)
    assert ensure_cache(load_gnm(root), (8, 8), cache_dir=cache, progress=False) != path  # other image size, other file


def test_epoch_sampler_shards_and_resumes():
    full = EpochSampler(10, seed=1)
    it = iter(full)
    first = [next(it) for _ in range(25)]
    assert sorted(i % 10 for i in first[:10]) == list(range(10)) and min(first[10:20]) >= 10
    it = iter(EpochSampler(10, seed=1, start=13))
    assert [next(it) for _ in range(12)] == first[13:25]
    r0, r1 = iter(EpochSampler(10, 1, 0, 2)), iter(EpochSampler(10, 1, 1, 2))
    a, b = [next(r0) for _ in range(5)], [next(r1) for _ in range(5)]
    assert sorted(a + b) == list(range(10))


def test_bad_inputs_name_the_culprit(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="holds no trajectory"):
        load_gnm(empty)
    with pytest.raises(ValueError, match="does not exist"):
        load_gnm(tmp_path / "missing")
    position, yaw = hand_trajectory()
    bad = tmp_path / "bad"
    write_traj(bad / "ok", position, yaw)
    (bad / "broken").mkdir()
    (bad / "broken" / "traj_data.pkl").write_bytes(b"not a pickle")
    with pytest.raises(ValueError, match=r"corrupt trajectory file .*broken"):
        load_gnm(bad)
    jpg = tmp_path / "jpg"
    write_traj(jpg / "t", position, yaw)
    (jpg / "t" / "4.jpg").write_bytes(b"\xff\xd8garbage")
    with pytest.raises(ValueError, match=r"cannot decode image .*4\.jpg"):
        ensure_cache(load_gnm(jpg), (16, 16), cache_dir=tmp_path / "cache", progress=False)
    assert not [p for p in (tmp_path / "cache").rglob("*") if p.is_file()]  # nothing half-written
    short = tmp_path / "short"
    write_traj(short / "long", position, yaw)
    write_traj(short / "tiny", position[:4], yaw[:4])
    with pytest.raises(ValueError, match="'tiny'.*has 4 frames"):
        make_dataset(short, nomad_small(), {"progress": False})
    ds = make_dataset(short, nomad_small(), {"progress": False, "skip_short": True})
    assert len(ds) == len(position) - 1 - 3
