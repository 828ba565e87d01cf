"""Renderer.render_batch: many views per call, byte-identical to one `render` per view, on both
back-ends, a procedural apartment, a textured room and the real dream apartment; its errors;
the base class's one-view-at-a-time default; render_parallel with a batch per call; render_views
across the renderers of several scenes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rvn_data.render import CameraConfig, make_renderer
from rvn_data.render.base import Renderer
from rvn_data.render.raycast import RaycastRenderer

from conftest import DREAM_APARTMENT as DREAM  # tests/ is on sys.path (pytest's prepend import mode)
from render_helpers import BACKENDS, coloured_room, navigable_poses, needs_egl


def one_at_a_time(renderer, poses):
    frames = [renderer.render(p, y) for p, y in poses]
    return np.stack([f[0] for f in frames]), np.stack([f[1] for f in frames])


def assert_batch_equals_single(renderer, poses, batch_views: int) -> None:
    """render_batch over passes of ``batch_views`` views (the last one partial), and in one pass,
    equals render per pose, byte for byte; without depth the same RGB and depth None."""
    renderer.batch_views = batch_views
    rgb, depth = renderer.render_batch(poses)
    want_rgb, want_depth = one_at_a_time(renderer, poses)
    cam = renderer.camera
    assert rgb.shape == (len(poses), cam.height, cam.width, 3) and rgb.dtype == np.uint8
    assert depth.shape == (len(poses), cam.height, cam.width) and depth.dtype == np.float32
    assert (depth > 0).mean() > 0.5  # the views see the scene
    np.testing.assert_array_equal(rgb, want_rgb)
    np.testing.assert_array_equal(depth, want_depth)
    rgb_only, none = renderer.render_batch(poses[:3], depth=False)
    assert none is None
    np.testing.assert_array_equal(rgb_only, want_rgb[:3])
    again, _ = renderer.render_batch(poses[-1:])  # a batch of one after bigger ones
    np.testing.assert_array_equal(again[0], want_rgb[-1])
    renderer.batch_views = len(poses)  # one pass for all: gl's staging buffer grows
    rgb, depth = renderer.render_batch(poses)
    np.testing.assert_array_equal(rgb, want_rgb)
    np.testing.assert_array_equal(depth, want_depth)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_equals_single_views_on_procedural_apartment_and_textured_room(backend):
    from rvn_data.scenes.procedural import make_apartment

    cam = CameraConfig(width=72, height=48, pitch_deg=-10.0)  # not square: rows and columns stay apart
    scene = make_apartment("train", 0)
    with make_renderer(scene, cam, backend) as r:
        assert_batch_equals_single(r, navigable_poses(scene, 11), batch_views=4)
    room = [([0.3, 0.0, 0.2], float(y)) for y in np.linspace(-3.0, 3.0, 7)]
    with make_renderer(coloured_room(), cam, backend) as r:  # checker texture on the floor
        assert_batch_equals_single(r, room, batch_views=64)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_equals_single_views_at_odd_image_sizes(backend):
    """85 x 63 (ViNT's aspect at an odd size): n colour images of W x H x 3 bytes end off a multiple of 4 bytes
    unless n is, where gl's staging buffer once put the depths after them (a float read there fails unreported:
    depth 0 or an earlier batch's)."""
    from rvn_data.scenes.procedural import make_apartment

    scene = make_apartment("train", 0)
    with make_renderer(scene, CameraConfig(width=85, height=63), backend) as r:
        assert_batch_equals_single(r, navigable_poses(scene, 7), batch_views=3)


@pytest.fixture(scope="module")
def dream():
    if not DREAM.exists():
        pytest.skip(f"{DREAM} not present")
    from rvn_data.scenes.loader import load_scene

    scene = load_scene(DREAM)
    return scene, navigable_poses(scene, 9, seed=5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_equals_single_views_on_dream_apartment(backend, dream):
    scene, poses = dream
    with make_renderer(scene, CameraConfig(), backend) as r:  # 256², textured real mesh
        assert_batch_equals_single(r, poses, batch_views=4)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_bad_input_is_one_line(backend):
    r = make_renderer(coloured_room(), CameraConfig(width=16, height=16), backend)
    for poses, says in (([], "no poses given"), (None, r"must be a list of \(position"),
                        ([([0, 0, 0], 0.0), ([0, 0], 1.0)], "pose 1 "),
                        ([([0, 0, 0], float("nan"))], "pose 0 "), ([(0.0, 0.0, 0.0)], "pose 0 ")):
        with pytest.raises(ValueError, match=says) as e:
            r.render_batch(poses)
        assert "\n" not in str(e.value) and "render_batch" in str(e.value)
    r.close()
    with pytest.raises(RuntimeError, match="closed"):
        r.render_batch([([0.0, 0.0, 0.0], 0.0)])


class LoopingRenderer(Renderer):
    """A back-end with only `render`: render_batch falls back to the base class's loop."""

    backend = "looping"

    def __init__(self, scene, camera):
        super().__init__(scene, camera)
        self.inner, self.calls = RaycastRenderer(scene, camera), 0

    def render(self, position, yaw, depth=True):
        self.calls += 1
        return self.inner.render(position, yaw, depth)

    def close(self):
        self.inner.close()


def test_base_default_renders_one_view_at_a_time():
    cam, poses = CameraConfig(width=24, height=20), [([0.1, 0.0, -0.2], y) for y in (0.0, 1.5, -2.0, 3.0, 0.4)]
    with LoopingRenderer(coloured_room(), cam) as r:
        r.batch_views = 2
        rgb, depth = r.render_batch(poses)
        assert r.calls == 5 and rgb.shape == (5, 20, 24, 3) and depth.shape == (5, 20, 24)
        want_rgb, want_depth = one_at_a_time(r.inner, poses)
        np.testing.assert_array_equal(rgb, want_rgb)
        np.testing.assert_array_equal(depth, want_depth)
        assert r.render_batch(poses[:2], depth=False)[1] is None


def test_render_parallel_with_batches_matches_single_views():
    from rvn_data.render.parallel import render_parallel

    room, cam = coloured_room(), CameraConfig(width=24, height=24)
    poses = [([0.2, 0.0, -0.3], y) for y in np.linspace(-math.pi, math.pi, 7, endpoint=False)]
    out = render_parallel(room, cam, poses, backend="raycast", processes=2, batch=3)
    assert out.rgb.shape == (7, 24, 24, 3) and out.frames == 7 and out.batch == 3
    with make_renderer(room, cam, "raycast") as r:
        want_rgb, want_depth = one_at_a_time(r, poses)
    np.testing.assert_array_equal(out.rgb, want_rgb)
    np.testing.assert_array_equal(out.depth, want_depth)
    with pytest.raises(ValueError, match="batch"):
        render_parallel(room, cam, poses, batch=0)


@needs_egl
def test_render_views_of_several_scenes_draws_each_context_in_one_pass(monkeypatch):
    """render_views over the views of two gl renderers (two scenes, one shared context) and a raycast
    one: each frame equals its renderer's own render(); the gl views take one pass, not one per view
    or per renderer; a closed renderer's view is an error."""
    from rvn_data.render import gl, render_views
    from rvn_data.scenes.procedural import make_apartment

    cam = CameraConfig(width=40, height=32)
    apartment, room = make_apartment("train", 1), coloured_room()
    passes = []
    real_pass = gl.GLRenderer._render_pass
    monkeypatch.setattr(gl.GLRenderer, "_render_pass",
                        lambda self, views, rgb, depth: (passes.append(len(views)), real_pass(self, views, rgb, depth)))
    with make_renderer(apartment, cam, "gl") as a, make_renderer(room, cam, "gl") as b, \
            make_renderer(room, cam, "raycast") as c:
        poses_a, poses_b = navigable_poses(apartment, 3), [([0.3, 0.0, 0.2], 0.4), ([-0.5, 0.0, 0.1], 2.0)]
        views = [(a, *poses_a[0]), (b, *poses_b[0]), (c, *poses_b[1]), (a, *poses_a[1]), (b, *poses_b[1]),
                 (a, *poses_a[2])]
        for depth in (True, False):
            passes.clear()
            frames = render_views(views, depth=depth)
            assert passes == [5]  # the five gl views in one pass; raycast batches its own
            for (renderer, position, yaw), (rgb, d) in zip(views, frames):
                want_rgb, want_depth = renderer.render(position, yaw)
                np.testing.assert_array_equal(rgb, want_rgb)
                if depth:
                    np.testing.assert_array_equal(d, want_depth)
                else:
                    assert d is None
        b.close()
        with pytest.raises(RuntimeError, match="closed"):
            render_views(views[:2])
