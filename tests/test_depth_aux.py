"""Auxiliary depth loss: rvn-gen dataset.save_depth sidecars, the depth cache and sample, and
rvn-train model.depth_aux_weight end to end (a tiny rvn-gen dataset, 3 training steps)."""
from __future__ import annotations

import json
import pickle
import shutil

import numpy as np
import pytest
import torch
from safetensors.torch import load_file
from conftest import interrupted_copy, run_python as run
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from rvn_data.dataset.writer import downsample_depth
from rvn_il.data import make_dataset, make_depth_frames
from rvn_il.models import build_model, load_model_config
from rvn_il.models.checkpoint import latest_checkpoint
from rvn_il.policies import load_policy
from rvn_il.policies.depth_veto import check_depth_veto as depth_veto_rule, clearance

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

torch.set_num_threads(1)
GEN = ["scenes.num_scenes=1", "trajectories_per_scene=2", "camera.width=32", "camera.height=32", "progress=false"]
TRAIN = ["model=nomad_pointgoal", "model.size=small", "train.max_steps=3", "train.batch_size=4", "train.log_every=1",
         "data.num_workers=0", "device=cpu"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    base = tmp_path_factory.mktemp("depth_aux")
    run("-m", "rvn_data.gen.cli", f"out_dir={base / 'depth'}", "dataset.save_depth=true", *GEN)
    run("-m", "rvn_data.gen.cli", f"out_dir={base / 'plain'}", *GEN)
    run("-m", "rvn_data.gen.cli", f"out_dir={base / 'negative'}", "dataset=negative", "dataset.save_depth=true", *GEN)
    return base


def trajectories(root):
    return sorted(p for p in root.iterdir() if (p / "traj_data.pkl").is_file())


def test_downsample_depth_is_a_block_mean_over_hits():
    depth = np.array([[1, 3, 0, 0], [2, 2, 0, 0], [4, 0, 5, 5], [0, 0, 5, 5]], np.float32)
    out = downsample_depth(depth, 2)
    assert out.dtype == np.float16 and out.shape == (2, 2)
    np.testing.assert_allclose(out, [[2.0, 0.0], [4.0, 5.0]])


def test_gen_writes_depth_of_every_frame(data):
    trajs = trajectories(data / "depth")
    assert len(trajs) == 2
    for t in trajs:
        depth = np.load(t / "depth.npy")
        frames = len(list(t.glob("*.jpg")))
        assert depth.dtype == np.float16 and depth.shape == (frames, 16, 16)
        assert (depth > 0).mean() > 0.9 and depth.max() < 20.0 and depth[depth > 0].min() > 0.01  # inside a flat
        assert len({depth[i].tobytes() for i in range(frames)}) > frames // 2  # the view changes along the path
    settings = json.loads((data / "depth" / ".rvn" / "settings.json").read_text())
    assert settings["save_depth"] is True and settings["depth_size"] == 16


def test_gen_without_depth_writes_what_it_did_before(data):
    plain, depth = trajectories(data / "plain"), trajectories(data / "depth")
    assert [p.name for p in plain] == [p.name for p in depth]
    for a, b in zip(plain, depth):
        assert sorted(f.name for f in a.iterdir()) == sorted(f.name for f in b.iterdir() if f.name != "depth.npy")
        for f in a.iterdir():  # the same frames and poses; only the settings record differs
            if f.name != "rvn_meta.json":
                assert f.read_bytes() == (b / f.name).read_bytes(), f
        assert "depth" not in (a / "rvn_meta.json").read_text()
    for f in ("manifest.json", ".rvn/settings.json"):
        assert "depth" not in (data / "plain" / f).read_text()
    assert "save_depth" in (data / "depth" / "manifest.json").read_text()


def test_negative_depth_repeats_the_collision_frame(data):
    for t in trajectories(data / "negative"):
        depth, t_c = np.load(t / "depth.npy"), json.loads((t / "rvn_meta.json").read_text())["t_c"]
        with open(t / "traj_data.pkl", "rb") as fh:
            assert len(depth) == len(pickle.load(fh)["position"]) == len(list(t.glob("*.jpg")))
        for i in range(t_c + 1, len(depth)):  # I_t = I_{t_c}, and so is its depth
            assert (depth[i] == depth[t_c]).all() and (t / f"{i}.jpg").read_bytes() == (t / f"{t_c}.jpg").read_bytes()


def test_samples_and_model_with_depth(data, tmp_path):
    cfg = load_model_config("nomad_pointgoal", "small", depth_aux_weight=0.5)
    ds = make_dataset(data / "depth", cfg, {"split": "train", "cache_dir": str(tmp_path), "progress": False})
    assert ds.cache.path.name.endswith("_depth16.h5")
    batch = ds.get_batch([0, 5])
    assert batch["depth"].dtype == torch.float32 and batch["depth"].shape == (2, 16, 16)
    first = trajectories(data / "depth")[0]
    cur = ds.curr[0] - ds.cache.traj_start[0]  # current frame (last of the context) of sample 0
    assert ds.cache.names[0] == first.name
    np.testing.assert_array_equal(batch["depth"][0].numpy(), np.load(first / "depth.npy")[cur].astype(np.float32))
    torch.manual_seed(0)
    losses = build_model(cfg)(batch, torch.Generator().manual_seed(0))
    assert losses["depth_loss"] > 0
    assert torch.allclose(losses["loss"], 1e-4 * losses["dist_loss"] + (1 - 1e-4) * losses["diffusion_loss"]
                          + 0.5 * losses["depth_loss"])
    # off (the default): no depth in the samples, no head, the weights and losses of before
    plain_cfg = load_model_config("nomad_pointgoal", "small")
    plain = make_dataset(data / "depth", plain_cfg, {"split": "train", "cache_dir": str(tmp_path), "progress": False})
    assert "depth" not in plain.get_batch([0]) and plain.cache.path != ds.cache.path
    torch.manual_seed(0)
    model = build_model(plain_cfg)
    assert not any(k.startswith("depth_head") for k in model.state_dict())
    assert set(model(batch, torch.Generator().manual_seed(0))) == {"loss", "dist_loss", "diffusion_loss"}
    torch.manual_seed(0)  # the head comes from a fork of the RNG: every other weight starts the same
    with_head = build_model(cfg).state_dict()
    for k, v in model.state_dict().items():
        assert torch.equal(v, with_head[k]), k


def test_train_with_depth_loss_end_to_end(data, tmp_path):
    out = tmp_path / "run"
    run("-m", "rvn_il.train.cli", *TRAIN, f"data.root={data / 'depth'}", f"out_dir={out}", "model.depth_aux_weight=0.5")
    ckpt = latest_checkpoint(out / "model")
    assert ckpt.name == "ckpt_00000003"
    for f in ("weights.safetensors", "ema.safetensors"):
        assert {"depth_head.0.weight", "depth_head.2.bias"} <= set(load_file(str(ckpt / f)))
    events = EventAccumulator(str(out / "tb" / "model"))
    events.Reload()
    assert {"train/depth_loss", "train/loss"} <= set(events.Tags()["scalars"])
    assert all(e.value > 0 for e in events.Scalars("train/depth_loss"))
    policy = load_policy(out)
    policy.reset()
    frame = np.full((32, 32, 3), 128, np.uint8)
    assert policy.act({"rgb": frame, "pointgoal": np.array([2.0, 0.5], np.float32)}) in (0, 1, 2, 3)
    check_depth_veto(out, frame)
    check_free_past_the_floor(out, data / "depth", frame)


def check_depth_veto(out, frame):
    """policy.depth_veto: a MOVE_FORWARD becomes a turn when the depth head predicts the way ahead
    blocked (here its output forced to 0.1 m), and stays when it predicts it open (5 m). The lookahead
    is set beyond every waypoint, so the policy steers at the point goal: forward when it lies ahead."""
    rng = np.random.default_rng(0)
    goals = [rng.uniform([-1, -3], [4, 3]).astype(np.float32) for _ in range(40)]

    def first_actions(policy, depth_m=None):
        if depth_m is not None:
            last = policy.members[0].model.depth_head[2]
            torch.nn.init.zeros_(last.weight)
            torch.nn.init.constant_(last.bias, float(np.log(depth_m)))
        out = []
        for g in goals:
            policy.reset()
            out.append((policy.act({"rgb": frame, "pointgoal": g}), policy.vetoes))
        return out

    steer = {"aggregate": "vote", "lookahead_min_dist": 50.0}
    plain = first_actions(load_policy(out, **steer))
    assert 0 < sum(a == 1 for a, _ in plain) < len(goals)
    open_ = first_actions(load_policy(out, depth_veto=0.5, **steer), depth_m=5.0)
    assert open_ == plain  # nothing vetoed: same actions, no veto counted
    blocked = first_actions(load_policy(out, depth_veto=0.5, **steer), depth_m=0.1)
    for (a, _), (b, vetoes) in zip(plain, blocked):
        assert (b, vetoes) == ((a, 0) if a != 1 else (b, 1)) and b != 1
    with pytest.raises(ValueError, match=r"policy.depth_veto=-1: give the clearance in metres"):
        load_policy(out, depth_veto=-1)
    # the swept rule, with the camera hfov rvn-train recorded from rvn-gen's data (the default camera's 90 degrees)
    assert json.loads((latest_checkpoint(out / "model") / "stats.json").read_text())["hfov_deg"] == 90.0
    swept = load_policy(out, depth_veto=0.5, depth_veto_rule="swept", **steer)
    assert swept.depth_veto.hfov_deg == 90.0 and swept.depth_veto.rule == "swept"
    assert first_actions(swept, depth_m=0.1) == blocked
    with pytest.raises(ValueError, match=r"policy.depth_veto_rule='wide'; choose band .* or swept"):
        load_policy(out, depth_veto=0.5, depth_veto_rule="wide")
    with pytest.raises(ValueError, match=r"policy.depth_veto_hfov=180: give the camera's horizontal field of view"):
        load_policy(out, depth_veto=0.5, depth_veto_rule="swept", depth_veto_hfov=180)
    check_escape(out, frame, first_actions)


def check_escape(out, frame, first_actions):
    """policy.escape_after through load_policy: a goal straight behind makes the policy turn; after 3 turns in
    place it drives escape_steps forward steps along the freest heading seen (the depth head forced to 5 m:
    every heading free, so the one nearest the goal), then hands back to the model; counted per episode."""
    steer = {"aggregate": "vote", "lookahead_min_dist": 50.0}
    policy = load_policy(out, escape_after=3, escape_steps=2, depth_veto=0.5, **steer)
    first_actions(policy, depth_m=5.0)  # sets the head's output
    policy.reset()
    behind = {"rgb": frame, "pointgoal": np.array([-3.0, 0.1], np.float32)}  # 178 deg to the left
    actions = [policy.act(behind) for _ in range(6)]
    # the observation is fixed, so the goal turns with the robot: after 3 turns (headings 0, 30, 60 deg) the goal
    # was last seen at 60 + 178 = 238 deg, nearest heading 0 (every heading free): two turns right, two steps
    assert actions == [2, 2, 3, 3, 1, 1] and policy.episode_stats()["escapes"] == 1
    policy.reset()
    assert policy.episode_stats() == {"decisions": 0, "vetoes": 0, "escapes": 0}
    plain = load_policy(out, **steer)
    plain.reset()
    assert [plain.act(behind) for _ in range(6)] == [2] * 6 and "escapes" not in plain.episode_stats()
    with pytest.raises(ValueError, match=r"policy.escape_after=0: give a whole number >= 1"):
        load_policy(out, escape_after=0)
    check_turn_commit(out, frame)


def check_turn_commit(out, frame):
    """policy.turn_commit through load_policy: a goal that switches sides every step makes the plain policy turn left,
    right, left...; with turn_commit it keeps turning left until it drives forward, counted per episode; the forward
    veto's turns are committed too."""
    steer = {"aggregate": "vote", "lookahead_min_dist": 50.0}  # steer at the point goal
    goals = [np.array(g, np.float32) for g in ([0.2, 1.0], [0.2, -1.0], [0.2, 1.0], [0.2, -1.0], [3.0, 0.0],
                                               [0.2, -1.0], [0.2, 1.0])]

    def actions(policy):
        policy.reset()
        return [policy.act({"rgb": frame, "pointgoal": g}) for g in goals]

    assert actions(load_policy(out, **steer)) == [2, 3, 2, 3, 1, 3, 2]
    committed = load_policy(out, turn_commit=True, **steer)
    assert actions(committed) == [2, 2, 2, 2, 1, 3, 3] and committed.episode_stats()["commits"] == 3
    assert "commits" not in load_policy(out, **steer).episode_stats()
    with pytest.raises(ValueError, match=r"policy.turn_commit='yes': give true or false"):
        load_policy(out, turn_commit="yes")


def check_free_past_the_floor(out, root, frame):
    """The escape's free metres and the veto look past the bare floor the depth grid's lower rows see (`Floor`, from
    the camera the checkpoint recorded). rvn-gen's rendered grids of this flat read the model's bare-floor depths in
    their lower rows, the bottom one 0.64 m whatever stands beyond: the nearest depth of their central columns never
    passed it, so escape_clearance (1 m) was met by no heading and a veto of 0.65 m or more blocked every step."""
    grids = np.concatenate([np.load(t / "depth.npy").astype(np.float32) for t in trajectories(root)])
    policy = load_policy(out, escape_after=3, depth_veto=0.7, aggregate="vote", lookahead_min_dist=50.0)
    floor = policy.floor
    np.testing.assert_allclose(np.median(grids[:, -3:, 4:12], axis=(0, 2)), floor.depths(16)[-3:], rtol=0.01)
    assert max(clearance(g) for g in grids) < 0.65
    free = [clearance(floor.standing(g)) if (g > 0).all() else 0.0 for g in grids]
    view = grids[int(np.argmax(free))]
    assert max(free) > 1.5 and policy.depth_veto.blocked(view) and not policy.depth_veto.blocked(floor.standing(view))
    last = policy.members[0].model.depth_head[2]  # the head forced to predict that view
    with torch.no_grad():
        last.weight.zero_()
        last.bias.copy_(torch.log(torch.from_numpy(view.reshape(-1))))
    policy.reset()
    assert policy.act({"rgb": frame, "pointgoal": np.array([-3.0, 0.1], np.float32)}) == 2  # the goal behind: a turn
    assert policy.escape.seen[0][1] == pytest.approx(max(free), rel=1e-3)


def test_escape_state_machine():
    """rvn_il.policies.escape.Escape on scripted model actions: after N turns in place it turns to the heading
    nearest the goal among those with enough clearance (else the freest; without depth, the goal's bearing),
    drives its steps unless the veto blocks one, and resets when the model drives by itself."""
    import math

    from rvn_il.policies.escape import Escape

    L, R, F = 2, 3, 1
    theta = math.radians(30)
    esc = Escape(after=4, theta_step=theta, steps=2, clearance=1.0)
    free = {0: 0.4, 1: 2.0, 2: 0.3, 3: 3.0}  # headings 0, 30, 60, 90 degrees (the model turns left)
    out = [esc.act(L, goal_bearing=-i * theta, free=free[i], blocked=False) for i in range(4)]  # the goal stays put
    # seen: 0 (0.4 m), 30 (2.0), 60 (0.3), 90 (3.0); goal at heading 0: nearest free one is 30 degrees
    assert out == [L, L, L, R] and esc.escapes == 1
    assert [esc.act(L, 0.0, 1.0, False) for _ in range(2)] == [R, F]  # one more right turn, then the drive
    assert esc.act(L, 0.0, 1.0, False) == F and esc.left == 0  # second step, back to the model
    assert esc.act(L, 0.0, 1.0, False) == L and len(esc.seen) == 1
    # no heading free enough: the freest; the veto blocks the drive: back to the model
    esc.reset()
    out = [esc.act(R, 0.0, f, False) for f in (0.5, 0.2, 0.9)]  # headings 0, -30, -60
    assert esc.escapes == 0 and out == [R, R, R]
    esc2 = Escape(after=3, theta_step=theta, steps=3, clearance=1.0)
    out = [esc2.act(R, 0.0, f, False) for f in (0.5, 0.2, 0.9)]
    assert out == [R, R, F]  # -60 (0.9 m) is the freest and where it stands
    assert esc2.act(R, 0.0, 0.9, blocked=True) == R and esc2.left == 0 and esc2.seen == []
    # without a depth head: the goal's bearing (90 degrees left of where the turning began)
    blind = Escape(after=2, theta_step=theta, steps=1)
    assert [blind.act(R, math.radians(90) + i * theta, None, False) for i in range(2)] == [R, L]
    assert [blind.act(R, 0.0, None, False) for _ in range(4)] == [L, L, L, F]
    # the model driving by itself resets the count
    esc.reset()
    assert [esc.act(a, 0.0, 1.0, False) for a in (L, F, L, L, L)] == [L, F, L, L, L] and esc.escapes == 0


def test_depth_veto_rules_on_depth_grids():
    """band: the nearest depth in the central half of the columns; swept: any cell inside the rectangle the
    step sweeps (|x| <= r_robot + max(0, z - d_step - r_robot), depth < z), x from the column's angle."""
    band, swept = depth_veto_rule(0.5, True), depth_veto_rule(0.5, True, "swept", 90.0, r_robot=0.18, d_step=0.25)
    side = np.full((16, 16), 5.0)
    side[8, 2] = 0.3  # column 2 of 16 at 90 deg: x = 0.3 * 0.6875 = 0.21 m, inside +-0.25 m, outside the band
    far_side = np.full((16, 16), 5.0)
    far_side[8, 0] = 0.3  # column 0: x = 0.28 m, beside the robot's path
    centre = np.full((16, 16), 5.0)
    centre[8, 8] = 0.45
    assert not band.blocked(side) and swept.blocked(side)
    assert not band.blocked(far_side) and not swept.blocked(far_side)
    assert band.blocked(centre) and swept.blocked(centre) and not swept.blocked(np.full((16, 16), 0.6))
    narrow = depth_veto_rule(0.5, True, "swept", 60.0)  # tan 30 deg: column 0 is at x = 0.3 * 0.56 = 0.17 m
    assert narrow.blocked(far_side)
    with pytest.raises(ValueError, match=r"needs the camera's hfov: this checkpoint does not record it .* "
                                         r"give policy.depth_veto_hfov=<degrees>"):
        depth_veto_rule(0.5, True, "swept", None)


def test_train_with_depth_loss_needs_depth(data, tmp_path):
    out = tmp_path / "bad"
    proc = run("-m", "rvn_il.train.cli", *TRAIN, f"data.root={data / 'plain'}", f"out_dir={out}",
               "model.depth_aux_weight=0.5", check=False)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert f"data.root={data / 'plain'} has no depth.npy sidecars" in lines[0]
    assert "dataset.save_depth=true" in lines[0] and "model.depth_aux_weight=0" in lines[0]
    assert not out.exists() and not (data / "plain" / ".rvn_cache").exists()


def test_depth_frames_are_every_frame_of_the_depth_root(data, tmp_path):
    cfg = load_model_config("nomad_pointgoal", "small", depth_aux_weight=0.5)
    frames = make_depth_frames(data / "negative", cfg, {"cache_dir": str(tmp_path), "progress": False})
    negatives = trajectories(data / "negative")
    depths = np.concatenate([np.load(t / "depth.npy") for t in negatives])
    assert len(frames) == len(depths)
    batch = frames[[len(depths) - 1, 0, len(depths) + 2]]  # indices past the end wrap (later epochs)
    assert batch["depth_image"].shape == (3, 3, *cfg["image_size"][::-1]) and batch["depth_image"].dtype == torch.uint8
    for row, i in enumerate([len(depths) - 1, 0, 2]):
        np.testing.assert_array_equal(batch["depth_target"][row].numpy(), depths[i].astype(np.float32))
    # the model adds their loss, with the depth weight, to what the samples give
    samples = make_dataset(data / "depth", cfg, {"split": "train", "cache_dir": str(tmp_path), "progress": False})
    torch.manual_seed(0)
    model = build_model(cfg).eval()  # no dropout: the two calls see the same weights and noise
    plain = model(samples.get_batch([0, 5]), torch.Generator().manual_seed(0))
    both = model({**samples.get_batch([0, 5]), **batch}, torch.Generator().manual_seed(0))
    assert both["depth_extra_loss"] > 0 and torch.allclose(both["depth_loss"], plain["depth_loss"])
    assert torch.allclose(both["loss"], plain["loss"] + 0.5 * both["depth_extra_loss"])
    with pytest.raises(ValueError, match=r"set model.depth_aux_weight > 0 or data.depth_root=null"):
        make_depth_frames(data / "negative", load_model_config("nomad_pointgoal", "small"), {"cache_dir": str(tmp_path)})


def test_train_with_depth_root_resumes_exactly(data, tmp_path):
    args = [*TRAIN[:2], "train.max_steps=4", "train.ckpt_every=2", *TRAIN[3:], f"data.root={data / 'depth'}",
            "model.depth_aux_weight=0.5", f"data.depth_root={data / 'negative'}", "data.depth_batch=3"]
    full = tmp_path / "full"
    run("-m", "rvn_il.train.cli", *args, f"out_dir={full}")
    events = EventAccumulator(str(full / "tb" / "model"))
    events.Reload()
    assert [e.step for e in events.Scalars("train/depth_extra_loss")] == [1, 2, 3, 4]
    assert all(e.value > 0 for e in events.Scalars("train/depth_extra_loss"))
    part = interrupted_copy(full, tmp_path / "part")  # an interrupted run: only the step-2 checkpoint survived
    run("-m", "rvn_il.train.cli", *args, f"out_dir={part}")
    a, b = latest_checkpoint(full / "model"), latest_checkpoint(part / "model")
    assert a.name == b.name == "ckpt_00000004"
    wa, wb = load_file(str(a / "weights.safetensors")), load_file(str(b / "weights.safetensors"))
    for k in wa:  # the resumed run drew the same depth frames at steps 3 and 4
        torch.testing.assert_close(wa[k], wb[k], rtol=0, atol=0, msg=k)


@pytest.mark.parametrize("extra, message", [
    (["model.depth_aux_weight=0"], "which model.depth_aux_weight=0 turns off; set model.depth_aux_weight > 0"),
    (["model.depth_aux_weight=0.5", "data.depth_root={plain}"], "data.depth_root={plain} has no depth.npy sidecars"),
    (["model.depth_aux_weight=0.5", "data.depth_batch=0"], "data.depth_batch=0 must be a positive integer"),
])
def test_depth_root_bad_input_one_line(data, tmp_path, extra, message):
    out = tmp_path / "bad"
    extra = [e.format(plain=data / "plain") for e in extra]
    root = [f"data.depth_root={data / 'negative'}"] if not any("depth_root" in e for e in extra) else []
    proc = run("-m", "rvn_il.train.cli", *TRAIN, f"data.root={data / 'depth'}", f"out_dir={out}", *root, *extra,
               check=False)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert message.format(plain=data / "plain") in lines[0]
    assert not out.exists()


def test_cache_with_depth_needs_every_sidecar(data, tmp_path):
    root = tmp_path / "partial"
    shutil.copytree(data / "depth", root)
    (trajectories(root)[1] / "depth.npy").unlink()
    cfg = load_model_config("nomad_pointgoal", "small", depth_aux_weight=0.5)
    with pytest.raises(ValueError, match=rf"dataset {root}: trajectory .*_0001 has no depth.npy; regenerate with "
                                         r"rvn-gen dataset.save_depth=true"):
        make_dataset(root, cfg, {"progress": False, "cache_dir": str(tmp_path / "cache")})
    assert not list((tmp_path / "cache").rglob("*.h5"))
    with pytest.raises(ValueError, match=r"model.depth_size=8; rvn-gen dataset.depth_size must match"):
        make_dataset(data / "depth", {**cfg, "depth_size": 8}, {"progress": False, "cache_dir": str(tmp_path)})
