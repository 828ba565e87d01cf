"""``data.crop`` = aspect | official | none: the official 4:3 crop of visualnav-transformer's
loader, one cache file per crop, the crop recorded in checkpoint stats and applied by
load_policy (older stats with ``crop_to_aspect`` still load)."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import torch

from rvn_il.data import crop_setting, load_gnm, make_dataset, preprocess_image
from rvn_il.data.cache import PackedCache, cache_path, ensure_cache
from rvn_data.dataset.reader import read_rgb
from rvn_il.data.synthetic import render_frame, write_synthetic_gnm
from rvn_il.models import load_model_config
from rvn_il.models.checkpoint import latest_checkpoint
from rvn_il.policies import load_policy
from rvn_il.train.cli import train

torch.set_num_threads(1)


def frame(w: int, h: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8)


def area(rgb: np.ndarray, size) -> np.ndarray:
    return cv2.resize(np.ascontiguousarray(rgb), tuple(size), interpolation=cv2.INTER_AREA)


@pytest.mark.parametrize("size", [(96, 96), (85, 64)])
def test_official_crop_is_the_visualnav_rule(size):
    # square 256x256: full width, height int(256 / (4/3)) = 192, 32 rows off the top and the bottom
    square = frame(256, 256)
    np.testing.assert_array_equal(preprocess_image(square, size, "official"), area(square[32:224], size))
    # 320x240 is 4:3 already: nothing cut, only the stretch to image_size
    wide = frame(320, 240, 1)
    np.testing.assert_array_equal(preprocess_image(wide, size, "official"), area(wide, size))
    # wider than 4:3 (400x240): height kept, width int(240 * 4/3) = 320, 40 columns off each side
    wider = frame(400, 240, 2)
    np.testing.assert_array_equal(preprocess_image(wider, size, "official"), area(wider[:, 40:360], size))
    # taller than wide (240x320): width kept, height int(240 / (4/3)) = 180 from row round(140 / 2) = 70
    tall = frame(240, 320, 3)
    np.testing.assert_array_equal(preprocess_image(tall, size, "official"), area(tall[70:250], size))


def test_official_crop_pads_like_torchvision_when_the_frame_is_narrower_than_4_3():
    """300x256: w > h asks for width int(256 * 4/3) = 341 > 300; torchvision's center_crop pads
    20 black columns on the left and 21 on the right."""
    rgb = frame(300, 256)
    out = preprocess_image(rgb, (341, 256), "official")
    assert out.shape == (256, 341, 3)
    assert not out[:, :20].any() and not out[:, -21:].any()
    np.testing.assert_array_equal(out[:, 20:320], rgb)


def test_aspect_and_none_unchanged_and_bad_values_named():
    rgb = frame(256, 192)
    np.testing.assert_array_equal(preprocess_image(rgb, (96, 96)), area(rgb[:, 32:224], (96, 96)))  # default aspect
    np.testing.assert_array_equal(preprocess_image(rgb, (96, 96), True), preprocess_image(rgb, (96, 96), "aspect"))
    np.testing.assert_array_equal(preprocess_image(rgb, (96, 96), "none"), area(rgb, (96, 96)))
    with pytest.raises(ValueError, match=r"data.crop='x'; choose aspect, official or none"):
        preprocess_image(rgb, (96, 96), "x")
    assert crop_setting({"crop": None}, {"crop_to_aspect": False}) == "none"
    assert crop_setting({}, None) == "aspect"
    assert crop_setting({"crop": "official"}, {"crop_to_aspect": True}) == "official"


def test_one_cache_file_per_crop(tmp_path):
    root = write_synthetic_gnm(tmp_path / "ds", 2, 12, image_size=32)
    src = load_gnm(root)
    paths = {c: ensure_cache(src, (16, 16), c, tmp_path / "cache", progress=False)
             for c in ("aspect", "official", "none")}
    assert paths["aspect"] == cache_path(src, (16, 16), True, tmp_path / "cache")
    assert paths["aspect"].name.endswith("_16x16_crop.h5")
    assert paths["none"].name.endswith("_16x16.h5") and paths["official"].name.endswith("_16x16_official.h5")
    first = np.asarray(PackedCache(paths["official"]).images[0]).transpose(1, 2, 0)
    want = preprocess_image(read_rgb(src.frame_path(0, 0)), (16, 16), "official")
    np.testing.assert_array_equal(first, want)
    assert not np.array_equal(first, np.asarray(PackedCache(paths["aspect"]).images[0]).transpose(1, 2, 0))
    cfg = load_model_config("vint_pointgoal", "small")
    with pytest.raises(ValueError, match=r"data.crop='square'; choose aspect, official or none"):
        make_dataset(root, cfg, {"crop": "square", "progress": False})


def test_train_with_official_crop_records_it_and_the_policy_applies_it(tmp_path):
    root = write_synthetic_gnm(tmp_path / "expert", 2, 16, image_size=64, seed=0)
    out = train(["model=vint_pointgoal", "model.size=small", f"data.root={root}", f"out_dir={tmp_path / 'run'}",
                 "data.crop=official", "data.num_workers=0", "train.max_steps=1", "train.batch_size=4"])
    stats_file = latest_checkpoint(out / "model") / "stats.json"
    stats = json.loads(stats_file.read_text())
    assert stats["crop"] == "official" and "crop_to_aspect" not in stats
    policy = load_policy(out)
    member = policy.members[0]
    assert member.crop == "official"
    rgb = render_frame(np.array([0.5, 0.0]), 0.3, 64)  # square: the aspect crop keeps it whole
    seen = []
    member.model.encode_frames = lambda x, **kw: seen.append(x) or x.flatten(1)  # record what the encoder is given
    policy.act({"rgb": rgb, "pointgoal": np.array([0.0, 0.0], np.float32)})  # at the goal: STOP, after the push
    for crop, same in (("official", True), ("aspect", False)):
        want = torch.from_numpy(preprocess_image(rgb, member.model.image_size, crop)).permute(2, 0, 1)[None] / 255.0
        assert torch.equal(seen[0], want) == same
    # stats written before data.crop: crop_to_aspect true/false → aspect/none
    for old, crop in ((True, "aspect"), (False, "none")):
        legacy = {k: v for k, v in stats.items() if k != "crop"} | {"crop_to_aspect": old}
        stats_file.write_text(json.dumps(legacy))
        assert load_policy(out).members[0].crop == crop
