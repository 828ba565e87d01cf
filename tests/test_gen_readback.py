"""rvn-gen end to end on tiny settings: GNM read-back, planar convention, negatives,
determinism (workers=1 vs 2), resume after an interrupted run."""
import hashlib
import json
import math
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

from rvn_data.conventions import Action, AgentConfig, from_planar, wrap_angle

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

TINY = ["scenes.num_scenes=2", "trajectories_per_scene=2", "camera.width=64", "camera.height=64", "progress=false"]
AGENT = AgentConfig()


def rvn_gen(*args, cwd=None, check=True, env=None):
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=600, env=None if env is None else {**os.environ, **env})
    if check and proc.returncode != 0:
        raise AssertionError(f"rvn-gen {' '.join(args)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return proc


def tree_hashes(root: Path) -> dict[str, str]:
    """sha256 of every dataset file: visible paths plus the scene records in .rvn/scenes
    (run bookkeeping such as .rvn/multirun, .rvn/tmp and temporary dot-files excluded)."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        visible = not any(part.startswith(".") for part in rel.split("/"))
        if p.is_file() and (visible or rel.startswith(".rvn/scenes/")):
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def gnm_load(root: Path, dataset: str, split: str):
    """Read a split the way visualnav-transformer's ViNT_Dataset does."""
    with open(root / "data_splits" / dataset / split / "traj_names.txt") as f:
        names = [n for n in f.read().split("\n") if n]
    out = {}
    for name in names:
        with open(os.path.join(root, name, "traj_data.pkl"), "rb") as f:
            data = pickle.load(f)
        pos = np.asarray(data["position"], dtype=np.float64)
        yaw = np.asarray(data["yaw"], dtype=np.float64).squeeze()
        images = [Image.open(os.path.join(root, name, f"{i}.jpg")).convert("RGB") for i in range(len(pos))]
        out[name] = (data, pos, yaw, images)
    return out


@pytest.fixture(scope="module")
def expert(tmp_path_factory):
    out = tmp_path_factory.mktemp("gen") / "expert"
    proc = rvn_gen(f"out_dir={out}", *TINY)
    return out, proc


@pytest.fixture(scope="module")
def negative(tmp_path_factory):
    out = tmp_path_factory.mktemp("gen") / "negative"
    proc = rvn_gen(f"out_dir={out}", "dataset=negative", *TINY)
    return out, proc


def check_convention(pos, yaw, actions, upto):
    """Frame t -> t+1 follows action t: forward 0.25 m along the heading, turns +-30 deg."""
    for t in range(upto):
        d = pos[t + 1] - pos[t]
        dyaw = float(wrap_angle(yaw[t + 1] - yaw[t]))
        a = actions[t]
        if a == Action.MOVE_FORWARD:
            assert np.allclose(d, AGENT.d_step * np.array([math.cos(yaw[t]), math.sin(yaw[t])]), atol=2e-3), (t, d)
            assert abs(dyaw) < 1e-9
        else:
            assert a in (Action.TURN_LEFT, Action.TURN_RIGHT)
            assert np.allclose(d, 0.0, atol=1e-9)
            assert math.isclose(dyaw, AGENT.theta_step * (1 if a == Action.TURN_LEFT else -1), abs_tol=1e-9)


def test_expert_reads_back_as_gnm(expert):
    out, proc = expert
    assert "trajectories kept 4/4" in proc.stdout, proc.stdout
    train, test = gnm_load(out, "rvn_expert", "train"), gnm_load(out, "rvn_expert", "test")
    assert len(train) == 2 and len(test) == 2  # split by scene: 1 scene each
    assert {n.rsplit("_expert_", 1)[0] for n in train}.isdisjoint({n.rsplit("_expert_", 1)[0] for n in test})
    for name, (data, pos, yaw, images) in {**train, **test}.items():
        assert set(data) == {"position", "yaw"}
        assert data["position"].dtype == np.float64 and data["position"].shape == (len(pos), 2)
        assert data["yaw"].dtype == np.float64 and data["yaw"].shape == (len(pos),)
        assert all(im.size == (64, 64) for im in images)
        assert cv2.imread(str(out / name / "0.jpg")).shape == (64, 64, 3)
        meta = json.loads((out / name / "rvn_meta.json").read_text())
        assert meta["frames"] == len(pos) and meta["kind"] == "expert" and meta["t_c"] is None
        assert meta["actions"][-1] == Action.STOP  # the goal was reached ...
        goal = np.asarray(meta["goal_planar"])
        assert np.hypot(*(pos[-1] - goal)) <= 2 * AGENT.r_robot + 1e-9  # ... within 2 r_robot
        assert 4.0 <= meta["path_length"] <= 8.0
        check_convention(pos, yaw, meta["actions"], len(pos) - 1)
    cfg = (out / "data_config.yaml").read_text()
    assert "rvn_expert:" in cfg and "metric_waypoint_spacing: 0.25" in cfg
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["trajectories"] == 4 and manifest["frames"] == sum(len(v[1]) for v in {**train, **test}.values())
    assert sorted(p.name for p in (out / "maps").iterdir()) == ["proc_train_0000.png", "proc_train_0001.png"]


def test_images_are_rgb_renders_of_the_recorded_pose(expert):
    from rvn_data.render import CameraConfig, make_renderer
    from rvn_data.scenes.procedural import make_apartment

    out, _ = expert
    name = sorted(p.name for p in out.iterdir() if p.name.startswith("proc_train_0000_expert"))[0]
    meta = json.loads((out / name / "rvn_meta.json").read_text())
    with open(out / name / "traj_data.pkl", "rb") as f:
        data = pickle.load(f)
    renderer = make_renderer(make_apartment("train", 0), CameraConfig(width=64, height=64), backend="auto")
    t = len(data["yaw"]) - 1
    rgb, _ = renderer.render(from_planar(data["position"][t], meta["start"][1]), float(data["yaw"][t]))
    renderer.close()
    img = np.asarray(Image.open(out / name / f"{t}.jpg").convert("RGB")).astype(np.float32)
    err = np.abs(img - rgb).mean()
    swapped = np.abs(img - rgb[:, :, ::-1]).mean()
    assert err < 12, err  # JPEG at quality 90
    assert err < swapped or np.abs(rgb.astype(float) - rgb[:, :, ::-1]).mean() < 2


def test_negative_clips(negative):
    from rvn_data.navmesh import NavMesh, NavMeshSettings
    from rvn_data.scenes.procedural import make_apartment
    from rvn_data.sim import Simulator

    out, proc = negative
    trajs = {**gnm_load(out, "rvn_negative", "train"), **gnm_load(out, "rvn_negative", "test")}
    assert len(trajs) == 4, proc.stdout
    navmeshes = {}
    for name, (data, pos, yaw, images) in trajs.items():
        meta = json.loads((out / name / "rvn_meta.json").read_text())
        t_c = meta["t_c"]
        assert len(pos) <= 8 + 6 + 1 and 0 <= t_c < len(pos)
        assert t_c == min(8, meta["t_c_episode"])
        raw = [(out / name / f"{i}.jpg").read_bytes() for i in range(len(pos))]
        assert all(r == raw[t_c] for r in raw[t_c + 1:])  # I_t = I_{t_c} after the collision
        assert len(pos) - 1 - t_c == 6 or meta["actions"][-1] == Action.STOP
        check_convention(pos, yaw, meta["actions"], len(pos) - 1)  # commanded poses included
        assert meta["actions"][t_c] == Action.MOVE_FORWARD
        # the simulator really collides on that step
        split, index = meta["spec"].split(":")[1].split("/")
        if meta["spec"] not in navmeshes:
            navmeshes[meta["spec"]] = NavMesh.build(make_apartment(split, int(index)), NavMeshSettings())
        sim = Simulator(navmeshes[meta["spec"]], AGENT)
        sim.reset(from_planar(pos[t_c], meta["start"][1]), float(yaw[t_c]))
        assert sim.step(Action.MOVE_FORWARD).collided
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["kind"] == "negative" and manifest["t_c"]["count"] == 4


def test_deterministic_across_workers(expert, tmp_path):
    """workers=2 writes workers=1's bytes; so do runs that keep their navmeshes under $RVN_CACHE_DIR (the first
    builds and writes them, the second reads them)."""
    out, _ = expert
    cache = {"RVN_CACHE_DIR": str(tmp_path / "cache")}
    proc = rvn_gen(f"out_dir={tmp_path / 'again'}", *TINY, "workers=2", env=cache)
    said = proc.stdout + proc.stderr  # the workers' renderer lines, in the run's console as with workers=1
    assert all(f"renderer for procedural:train/{i}: " in said for i in (0, 1)), said
    assert len(list((tmp_path / "cache" / "navmesh").glob("*.npz"))) == 2
    rvn_gen(f"out_dir={tmp_path / 'third'}", *TINY, env=cache)
    one = tree_hashes(out)
    assert any(k.endswith("traj_data.pkl") for k in one) and any(k.endswith(".jpg") for k in one), sorted(one)[:5]
    assert tree_hashes(tmp_path / "again") == one and tree_hashes(tmp_path / "third") == one


def test_resume_after_interruption(expert, tmp_path):
    out, _ = expert
    d = tmp_path / "resume"
    rvn_gen(f"out_dir={d}", *TINY[:1], "trajectories_per_scene=1", *TINY[2:])  # a smaller run first
    assert not (d / "proc_train_0000_expert_0001").exists()
    # a full run killed as soon as it has written one more trajectory
    proc = subprocess.Popen([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={d}", *TINY],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < deadline:
        if (d / "proc_train_0000_expert_0001").exists():
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.05)
    proc.wait()
    for p in d.iterdir():  # every trajectory folder is complete
        if p.name.startswith("proc_"):
            meta = json.loads((p / "rvn_meta.json").read_text())
            assert sorted(x.name for x in p.iterdir()) == sorted(
                [f"{i}.jpg" for i in range(meta["frames"])] + ["traj_data.pkl", "rvn_meta.json"])
    # and a deleted trajectory plus a half-written leftover
    victim = "proc_train_0001_expert_0000"
    if (d / victim).exists():
        for f in (d / victim).iterdir():
            f.unlink()
        (d / victim).rmdir()
    (d / ".rvn" / "scenes" / "proc_train_0001.json").unlink(missing_ok=True)
    (d / ".rvn" / "tmp" / victim).mkdir(parents=True, exist_ok=True)
    (d / ".rvn" / "tmp" / victim / "0.jpg").write_bytes(b"partial")
    proc = rvn_gen(f"out_dir={d}", *TINY)
    assert tree_hashes(d) == tree_hashes(out)
    assert not any((d / ".rvn" / "tmp").iterdir())


def test_settings_change_is_refused(expert):
    out, _ = expert
    proc = rvn_gen(f"out_dir={out}", *TINY, "dataset.margin=0.3", check=False)
    assert proc.returncode != 0
    assert "dataset.margin" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.parametrize("anywhere", [True, False])
def test_expert_starts_anywhere_on_the_navmesh(tmp_path, anywhere):
    """Benchmark starts are any navigable pose, also inside the expert margin (next to a wall):
    with dataset.start_anywhere (default) expert trajectories start there too and first leave
    the margin; with false every start clears the margin."""
    from rvn_data.planning import occupancy_grid
    from rvn_data.scenes.loader import load_scene

    out = tmp_path / "ds"
    rvn_gen(f"out_dir={out}", "scenes.num_scenes=1", "trajectories_per_scene=24", "camera.width=16",
            "camera.height=16", "progress=false", f"dataset.start_anywhere={str(anywhere).lower()}")
    metas = [json.loads(p.read_text()) for p in sorted(out.glob("*/rvn_meta.json"))]
    assert len(metas) == 24
    grid = occupancy_grid(load_scene("procedural:train/0"), metas[0]["start"][1], 0.05)
    clearance = grid.clearance()
    margin = AGENT.r_robot + 0.1
    inside = 0
    for m in metas:
        r, c = grid.to_cell(np.asarray(m["start"]))
        assert clearance[r, c] > AGENT.r_robot - 0.05  # navigable: never closer than r_robot (± a cell)
        inside += clearance[r, c] <= margin
        assert m["actions"][-1] == Action.STOP  # reached the goal without collision all the same
    assert (inside > 0) == anywhere, inside


def test_heading_perturbations_keep_the_expert_labels(tmp_path):
    """dataset.perturb_prob: the expert is made to turn off its heading now and then and turns
    back by itself; turns never move the robot, so the positions (the GNM labels) are the
    unperturbed expert's path, frame for frame, with the perturbed frames added in place."""
    runs = {}
    for p in (0.0, 0.3):
        out = tmp_path / f"p{p}"
        rvn_gen(f"out_dir={out}", "scenes.num_scenes=1", "trajectories_per_scene=6", "camera.width=16",
                "camera.height=16", "progress=false", f"dataset.perturb_prob={p}")
        runs[p] = [json.loads(m.read_text()) for m in sorted(out.glob("*/rvn_meta.json"))]
        for m in runs[p]:
            assert m["actions"][-1] == Action.STOP  # the goal is reached without a collision all the same
    plain, perturbed = runs[0.0], runs[0.3]
    assert [m["start"] for m in plain] == [m["start"] for m in perturbed]  # same draws, same plans
    extra = 0
    for a, b in zip(plain, perturbed):
        pa = pickle.loads((tmp_path / "p0.0" / a["name"] / "traj_data.pkl").read_bytes())["position"]
        pb = pickle.loads((tmp_path / "p0.3" / b["name"] / "traj_data.pkl").read_bytes())["position"]
        moved_a = pa[np.r_[True, np.any(np.diff(pa, axis=0) != 0, axis=1)]]
        moved_b = pb[np.r_[True, np.any(np.diff(pb, axis=0) != 0, axis=1)]]
        np.testing.assert_allclose(moved_a, moved_b, atol=1e-9)  # the same places visited, in order
        extra += len(b["actions"]) - len(a["actions"])
    assert extra >= 6  # turns away and back were added
    bad = rvn_gen(f"out_dir={tmp_path / 'bad'}", "scenes.num_scenes=1", "dataset.perturb_prob=1.5", check=False)
    assert bad.returncode != 0 and "dataset.perturb_prob=1.5" in bad.stderr, bad.stderr
