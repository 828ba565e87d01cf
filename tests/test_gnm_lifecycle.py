"""The GNM writer lifecycle (open -> write_trajectory -> close_scene -> finalise) and the one
reader, through their public APIs on a tiny hand-made dataset."""
import json

import numpy as np
import pytest

from rvn_data.dataset.gnm_writer import GNMWriter
from rvn_data.dataset.naming import scene_slug, traj_name
from rvn_data.dataset.reader import list_trajectories, load_gnm, read_meta, read_rgb
from rvn_data.config import typed
from rvn_data.config_schemas import GenConfig
from rvn_data.dataset.settings import GenSettings
from rvn_data.dataset.writer import encode_jpeg


def _settings(seed=0):
    return GenSettings.resolve(typed(GenConfig, {"dataset": {"train_fraction": 0.5}, "agent": {}, "seed": seed,
                                    "camera": {"width": 8, "height": 8}}))


def test_writer_lifecycle_then_reader(tmp_path):
    s = _settings()
    specs = ["procedural:train/0", "procedural:train/1"]
    gnm = GNMWriter.open(tmp_path, s)
    jpeg = encode_jpeg(np.full((8, 8, 3), 64, np.uint8), 90)
    d = s.agent.d_step
    for spec in specs:
        slug = scene_slug(spec)
        name = traj_name(slug, s.kind, 0)
        pos, yaw = np.array([[0.0, 0.0], [d, 0.0], [2 * d, 0.0]]), np.zeros(3)
        gnm.write_trajectory(name, [jpeg] * 3, pos, yaw, {"name": name, "frames": 3}, depth=np.ones((3, 4, 4), np.float32))
        assert gnm.done_trajectory(name) == {"name": name, "frames": 3}
        assert gnm.missing_scenes(specs) != []
        gnm.close_scene(slug, {"scene": slug, "spec": spec, "trajectories": [
            {"name": name, "frames": 3, "t_c": 0, "path_length": 2 * d}], "failed": [], "rejected": {},
            "attempts": 1, "renderers": ["gl"]})
        assert gnm.scene_record(slug)["spec"] == spec
    assert gnm.finalise(specs) == []
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["trajectories"] == 2 and manifest["scenes"]["done"] == 2
    # the reader sees what the writer wrote: splits, poses, frames, sidecars
    train = list_trajectories(tmp_path, "train")[1]
    test = list_trajectories(tmp_path, "test")[1]
    assert sorted(train + test) == sorted(traj_name(scene_slug(x), s.kind, 0) for x in specs)
    src = load_gnm(tmp_path, "train" if train else "test")
    assert src.spacing == pytest.approx(d) and list(src.lengths) == [3]
    assert read_rgb(src.frame_path(0, 2)).shape == (8, 8, 3)
    assert read_meta(tmp_path / src.names[0]) == {"name": src.names[0], "frames": 3}
    assert (tmp_path / src.names[0] / "depth.npy").is_file()
    # resume with the same settings works; other settings are refused, naming the setting
    GNMWriter.open(tmp_path, _settings())
    with pytest.raises(ValueError, match="seed"):
        GNMWriter.open(tmp_path, _settings(seed=1))
