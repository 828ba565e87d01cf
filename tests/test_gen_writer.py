"""GNM writer and dataset finalisation pieces (fast, no scene)."""
import pickle

import cv2
import numpy as np
import pytest

from rvn_data.dataset import naming
from rvn_data.dataset.finalise import split_scenes
from rvn_data.dataset.reader import is_complete, load_gnm, load_traj_data, read_meta, read_rgb, rvn_trajectories
from rvn_data.dataset.writer import encode_jpeg, write_trajectory


def test_jpeg_is_rgb_on_disk():
    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[..., 0] = 200  # red
    bgr = cv2.imdecode(np.frombuffer(encode_jpeg(rgb, 95), np.uint8), cv2.IMREAD_COLOR)
    assert bgr[..., 2].mean() > 190 and bgr[..., 0].mean() < 10  # OpenCV reads it back as red
    assert encode_jpeg(rgb, 95) == encode_jpeg(rgb.copy(), 95)


def test_write_trajectory_layout_and_atomicity(tmp_path):
    jpeg = encode_jpeg(np.full((8, 8, 3), 128, np.uint8), 90)
    pos, yaw = np.array([[0.0, 0.0], [0.25, 0.0]]), np.array([0.0, 0.0])
    write_trajectory(tmp_path, "t_0000", [jpeg, jpeg], pos, yaw, {"k": 1})
    assert is_complete(tmp_path / "t_0000")
    assert sorted(p.name for p in (tmp_path / "t_0000").iterdir()) == ["0.jpg", "1.jpg", "rvn_meta.json", "traj_data.pkl"]
    with open(tmp_path / "t_0000" / "traj_data.pkl", "rb") as f:
        data = pickle.load(f)
    assert data["position"].dtype == np.float64 and data["yaw"].shape == (2,)
    with pytest.raises(ValueError):
        write_trajectory(tmp_path, "t_0001", [jpeg], pos, yaw, {})
    assert not (tmp_path / "t_0001").exists()
    # the one reader reads back what the writer wrote
    assert rvn_trajectories(tmp_path) == ["t_0000"] and read_meta(tmp_path / "t_0000") == {"k": 1}
    back_pos, back_yaw = load_traj_data(tmp_path / "t_0000")
    np.testing.assert_array_equal(back_pos, pos) and np.testing.assert_array_equal(back_yaw, yaw)
    assert read_rgb(tmp_path / "t_0000" / "1.jpg").shape == (8, 8, 3)
    source = load_gnm(tmp_path)
    assert source.names == ["t_0000"] and source.spacing == 0.25 and list(source.lengths) == [2]
    (tmp_path / "t_0000" / "traj_data.pkl").write_bytes(b"junk")
    with pytest.raises(ValueError, match="corrupt trajectory file .*traj_data.pkl"):
        load_traj_data(tmp_path / "t_0000")


def test_scene_split_is_seeded_disjoint_and_stable():
    slugs = [f"proc_train_{i:04d}" for i in range(10)]
    train, test = split_scenes(slugs, 0, 0.8)
    assert len(test) == 2 and set(train).isdisjoint(test) and sorted(train + test) == slugs
    assert split_scenes(list(reversed(slugs)), 0, 0.8) == (train, test)
    assert split_scenes(slugs, 1, 0.8) != (train, test)
    assert split_scenes(slugs[:2], 0, 0.8)[1] != [] and split_scenes(slugs[:1], 0, 0.8) == (slugs[:1], [])


def test_names_and_seeds():
    assert naming.scene_slug("procedural:train/12") == "proc_train_0012"
    assert naming.scene_slug("/data/hm3d/train/00800-TEEsavR23oF/TEEsavR23oF.basis.glb") == "TEEsavR23oF.basis"
    assert naming.traj_name("proc_train_0012", "negative", 3) == "proc_train_0012_negative_0003"
    a = naming.attempt_rng(0, "expert", "proc_train_0001", 2, 0).random()
    assert a == naming.attempt_rng(0, "expert", "proc_train_0001", 2, 0).random()
    assert a != naming.attempt_rng(0, "negative", "proc_train_0001", 2, 0).random()
    with pytest.raises(ValueError, match="share"):
        naming.check_unique(["/a/x.glb", "/b/x.glb"])


def test_building_the_renderer_counts_as_set_up(tmp_path, monkeypatch):
    """rvn-gen's time shares (benchmarks/gen.py, the node benchmark): the renderer is built at a scene's first frame to
    render, and that time belongs to set-up (scene, navmesh, renderer), not to no phase at all."""
    import time

    import rvn_data.render
    from rvn_data.config import load_config
    from rvn_data.gen.run import generate

    real = rvn_data.render.make_renderer

    def slow(*args, **kwargs):
        time.sleep(4.0)  # more than the scene and navmesh take (~1 s)
        return real(*args, **kwargs)

    monkeypatch.setattr(rvn_data.render, "make_renderer", slow)
    cfg = load_config("gen", [f"out_dir={tmp_path / 'o'}", "progress=false", "scenes.num_scenes=1",
                              "trajectories_per_scene=1", "camera.width=32", "camera.height=32", "workers=1"])
    report = generate(cfg)
    assert report.status == 0 and report.results[0].written == 1
    assert report.results[0].timing["setup"] >= 4.0
