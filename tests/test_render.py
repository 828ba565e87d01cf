"""Renderer: camera geometry, the two back-ends' agreement, materials, `auto`, views, workers."""
from __future__ import annotations

import io
import json
import logging
import math

import numpy as np
import pytest
import trimesh
from PIL import Image

from rvn_data.render import CameraConfig, make_renderer
from rvn_data.scenes import Part, Scene, SceneError

from conftest import DREAM_APARTMENT as DREAM  # tests/ is on sys.path (pytest's prepend import mode)
from render_helpers import BACKENDS, box, coloured_room, egl_error, navigable_poses, needs_egl


def compare(scene: Scene, poses, camera: CameraConfig):
    """Worst-pose fractions (depth within 1 cm, equal hit mask) and RGB mean abs diff /255."""
    gl, rc = make_renderer(scene, camera, "gl"), make_renderer(scene, camera, "raycast")
    depth_ok, mask_ok, mad = [], [], []
    try:
        for p, yaw in poses:
            (a, da), (b, db) = gl.render(p, yaw), rc.render(p, yaw)
            depth_ok.append(np.mean(np.abs(da - db) <= 0.01))
            mask_ok.append(np.mean((da > 0) == (db > 0)))
            mad.append(np.abs(a.astype(np.int16) - b).mean())
    finally:
        gl.close(), rc.close()
    return min(depth_ok), min(mask_ok), max(mad)


# ---- camera ---------------------------------------------------------------------------
@pytest.mark.parametrize("kw,name", [({"width": 0}, "width"), ({"height": -3}, "height"),
                                     ({"hfov_deg": 180}, "hfov_deg"), ({"hfov_deg": 0}, "hfov_deg"),
                                     ({"near": 1.0, "far": 0.5}, "near"), ({"near": 0.0}, "near"),
                                     ({"fx": -10.0}, "fx"), ({"fy": 0.0}, "fy"), ({"pitch_deg": 95}, "pitch_deg"),
                                     ({"cx": float("nan")}, "cx")])
def test_bad_camera_settings_name_the_setting(kw, name):
    with pytest.raises(ValueError, match=name):
        CameraConfig(**kw)


def test_camera_from_dict_and_intrinsics():
    cam = CameraConfig.from_dict({"width": 64.0, "height": 32, "fx": 40.0, "cy": 10.0})
    assert (cam.width, cam.focal, cam.principal) == (64, (40.0, 40.0), (32.0, 10.0))
    assert np.allclose(CameraConfig(width=100, hfov_deg=90).intrinsics()[0, 0], 50.0)
    with pytest.raises(ValueError, match="unknown camera setting"):
        CameraConfig.from_dict({"fov": 90})
    with pytest.raises(ValueError, match="backend"):
        make_renderer(coloured_room(), cam, backend="vulkan")
    with pytest.raises(SceneError, match="no triangles"):
        make_renderer(Scene("test:empty"), cam, backend="raycast")


@pytest.mark.parametrize("backend", BACKENDS)
def test_planar_depth_and_intrinsics_on_analytic_wall(backend):
    """A 1 m x 0.6 m wall 2 m ahead: exact planar depth at every pixel; its outline follows fx, fy, cx, cy."""
    cam = CameraConfig(width=48, height=40, fx=30.0, fy=22.0, cx=20.0, cy=24.0, pitch_deg=10.0)
    wall = Part("wall", [[2, 0.3, -0.5], [2, 0.3, 0.5], [2, 0.9, 0.5], [2, 0.9, -0.5]], [[0, 1, 2], [0, 2, 3]])
    with make_renderer(Scene("test:wall", [wall]), cam, backend) as r:
        rgb, depth = r.render([0.0, 0.0, 0.0], 0.0)
    assert rgb.shape == (40, 48, 3) and rgb.dtype == np.uint8 and depth.dtype == np.float32
    p = math.radians(10.0)
    yc = -(np.arange(40) + 0.5 - 24.0) / 22.0  # camera-frame ray (xc, yc, -1) per pixel
    xc = (np.arange(48) + 0.5 - 20.0) / 30.0
    t = 2.0 / (math.cos(p) - yc * math.sin(p))  # distance along the optical axis to x = 2
    z = xc[None, :] * t[:, None]  # world z of the hit (the camera's right is +z at yaw 0)
    y = 0.6 + t * (math.sin(p) + yc * math.cos(p))
    inside = (np.abs(z) < 0.5) & ((y > 0.3) & (y < 0.9))[:, None]
    margin = (np.abs(np.abs(z) - 0.5) < 0.03) | (np.minimum(np.abs(y - 0.3), np.abs(y - 0.9)) < 0.03)[:, None]
    assert np.array_equal((depth > 0)[~margin], inside[~margin]) and inside.sum() > 60
    assert np.allclose(depth[inside & ~margin], np.broadcast_to(t[:, None], depth.shape)[inside & ~margin],
                       atol=1e-4)
    assert np.ptp(depth[inside & ~margin]) > 0.05  # pitched: rows differ, off-centre rows exact too


@pytest.mark.parametrize("backend", BACKENDS)
def test_orientation_turning_left_and_near_far_clipping(backend):
    """Yaw 0 looks east (+x, blue); yaw +45 deg shows north (red) on the left, east on the right."""
    room = coloured_room()
    with make_renderer(room, CameraConfig(width=32, height=32), backend) as r:
        rgb, _ = r.render([0.0, 0.0, 0.0], 0.0)
        assert rgb[8, 16, 2] > 100 and rgb[8, 16, :2].max() == 0
        rgb, _ = r.render([0.0, 0.0, 0.0], math.pi / 4)
        assert rgb[8, 4, 0] > 100 and rgb[8, 4, 1:].max() == 0  # north, left
        assert rgb[8, 27, 2] > 100 and rgb[8, 27, :2].max() == 0  # east, right
        assert rgb[28, 16].min() > 0  # floor below the horizon (y up, not flipped)
    with make_renderer(room, CameraConfig(width=16, height=16, far=1.5), backend) as r:
        _, depth = r.render([0.0, 0.0, 0.0], 0.0)
        assert depth[4].max() == 0 and 0 < depth[15].min() <= 1.5  # wall at 2 m clipped, floor kept
    with make_renderer(room, CameraConfig(width=16, height=16, forward_offset=0.5, h_camera=1.2), backend) as r:
        _, depth = r.render([0.5, 0.0, 0.0], 0.0)
        assert np.allclose(depth[4:8], 1.0, atol=1e-4)  # east wall at x = 2, camera at x = 1


@needs_egl
def test_backends_agree_on_room_and_procedural_apartment():
    from rvn_data.scenes.procedural import make_apartment

    cam = CameraConfig(width=128, height=128)
    room = [([0.3, 0.0, 0.2], y) for y in np.linspace(-3.0, 3.0, 5)]
    for scene, poses in ((coloured_room(), room), (make_apartment("train", 0), None)):
        poses = poses or navigable_poses(scene, 8)
        depth_ok, mask_ok, mad = compare(scene, poses, cam)
        assert depth_ok >= 0.99 and mask_ok >= 0.995 and mad <= 3.0, (scene.scene_id, depth_ok, mask_ok, mad)


@needs_egl
@pytest.mark.skipif(not DREAM.exists(), reason=f"{DREAM} not present")
def test_backends_agree_on_dream_apartment():
    from rvn_data.scenes.loader import load_scene

    scene = load_scene(DREAM)
    depth_ok, mask_ok, mad = compare(scene, navigable_poses(scene, 6), CameraConfig(width=128, height=128))
    assert depth_ok >= 0.99 and mask_ok >= 0.995 and mad <= 3.0, (depth_ok, mask_ok, mad)


@needs_egl
def test_gl_renderers_in_one_process_share_one_context_and_draw_as_alone():
    """Renderers of two scenes share the process's EGL context (an RL worker's envs: no context switch between
    scenes), interleaved frames are byte-identical to renderers with contexts of their own, and the context goes
    when the last renderer closes."""
    from rvn_data.render import gl

    cam, room = CameraConfig(width=24, height=24), coloured_room()
    other = Scene("test:other", [box("wall", [1, 0, -3], [1.2, 3, 3], (0, 1, 1, 1))])
    alone = [gl.GLRenderer(scene, cam, ctx=gl.create_context(0)) for scene in (room, other)]  # own contexts
    a = make_renderer(room, cam, "gl")
    b = make_renderer(other, cam, "gl")
    assert a.ctx is b.ctx and alone[0].ctx is not a.ctx
    poses = [([0.0, 0.0, 0.0], 0.0), ([0.3, 0.0, 0.2], 1.0), ([-0.2, 0.0, 0.1], -2.0)]
    for pose in poses:  # a, b, a, b, ...: each draw sets the state it uses
        for shared, own in zip((a, b), alone):
            got, want = shared.render(*pose), own.render(*pose)
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    for r in alone:
        r.close()
    a.close()
    assert np.array_equal(b.render(*poses[0])[0], alone_frame(other, cam, poses[0]))  # the context lives on for b
    b.close()
    assert 0 not in gl._SHARED  # released with the last renderer
    with pytest.raises(RuntimeError, match="closed"):
        b.render([0.0, 0.0, 0.0], 0.0)


@needs_egl
@pytest.mark.skipif(not DREAM.exists(), reason=f"{DREAM} not present")
def test_gl_mesh_arrays_made_ahead_draw_the_same_bytes():
    """A GL renderer given its scene's `mesh_arrays` made ahead and pickled (as rvn-rl's scene prefetch has a
    helper process make them) draws byte for byte what one that makes them itself draws: the dream apartment, a
    procedural apartment and a room with a textured floor, RGB and depth."""
    import pickle

    from rvn_data.render.mesh_arrays import mesh_arrays
    from rvn_data.scenes.loader import load_scene
    from rvn_data.scenes.procedural import make_apartment

    cam = CameraConfig(width=48, height=40)
    room = [([0.3, 0.0, 0.2], y) for y in np.linspace(-3.0, 3.0, 4)]
    textured = 0
    for scene, poses in ((load_scene(DREAM), None), (make_apartment("train", 1), None), (coloured_room(), room)):
        arrays = pickle.loads(pickle.dumps(mesh_arrays(scene)))
        textured += any(p is not None and p[1] is not None for p in arrays.parts)
        with make_renderer(scene, cam, "gl") as plain, make_renderer(scene, cam, "gl", gl_arrays=arrays) as ahead:
            for pose in poses or navigable_poses(scene, 4):
                (a, da), (b, db) = plain.render(*pose), ahead.render(*pose)
                assert np.array_equal(a, b) and np.array_equal(da, db)
    assert textured == 2  # the procedural apartment's and the room's textures


def alone_frame(scene, cam, pose) -> np.ndarray:
    from rvn_data.render import gl

    r = gl.GLRenderer(scene, cam, ctx=gl.create_context(0))
    try:
        return r.render(*pose)[0]
    finally:
        r.close()


@needs_egl
def test_gl_without_depth_skips_its_read_back_and_keeps_the_rgb():
    r = make_renderer(coloured_room(), CameraConfig(width=24, height=24), "gl")
    rgb, depth = r.render([0.0, 0.0, 0.0], 0.7)
    rgb_only, none = r.render([0.0, 0.0, 0.0], 0.7, depth=False)
    assert none is None and depth is not None and np.array_equal(rgb, rgb_only)
    r.close()


def test_chunk_culling_skips_what_is_behind_the_camera():
    from rvn_data.render.chunks import build_chunks, order_faces, visible_runs

    grid = trimesh.creation.box(extents=[0.1, 0.1, 0.1])  # 12 faces per box, 400 boxes on a 20 x 20 m grid
    boxes = [grid.copy().apply_translation([x, 0.5, z]) for x in range(-10, 10) for z in range(-10, 10)]
    mesh = trimesh.util.concatenate(boxes)
    faces, spans = order_faces(mesh.vertices.astype(np.float32), mesh.faces)
    assert sorted(map(tuple, np.sort(faces, axis=1))) == sorted(map(tuple, np.sort(mesh.faces, axis=1)))
    chunks = build_chunks([spans])
    cam = CameraConfig(width=16, height=16)
    mvp = cam.projection_matrix() @ cam.view_matrix([0.0, 0.0, 0.0], 0.0)  # looking along +x
    runs = visible_runs(chunks, mvp)
    drawn = sum(c for _, _, c in runs)
    assert len(chunks.part) > 20 and 0 < drawn < 0.7 * 3 * len(faces)
    drawn_chunks = [(f, c) for _, f, c in runs]
    centres_behind = chunks.centre[:, 0] + chunks.radius < 0
    for first, count in zip(chunks.first[centres_behind], chunks.count[centres_behind]):
        assert not any(f <= first < f + c for f, c in drawn_chunks)


# ---- materials --------------------------------------------------------------------------
@pytest.mark.parametrize("backend", BACKENDS)
def test_mesh_without_materials_renders_grey(backend, tmp_path):
    from rvn_data.scenes.loader import load_scene

    trimesh.creation.box(bounds=[[1.5, 0, -1], [1.6, 2, 1]]).export(tmp_path / "plain.ply")
    scene = load_scene(tmp_path / "plain.ply")
    with make_renderer(scene, CameraConfig(width=16, height=16), backend) as r:
        rgb, depth = r.render([0.0, 0.0, 0.0], 0.0)
    c = rgb[8, 8].astype(int)
    assert depth[8, 8] > 0 and c.min() > 60 and c.max() - c.min() <= 1


@pytest.mark.parametrize("fmt", ["PNG", "JPEG"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_embedded_glb_texture_renders_its_colours(backend, fmt, tmp_path):
    """A quad facing the camera, textured red (left of the image) and blue (right)."""
    from rvn_data.scenes.loader import load_scene

    img = np.zeros((32, 32, 3), np.uint8)
    img[:, :16] = (255, 0, 0)
    img[:, 16:] = (0, 0, 255)
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format=fmt)
    image = Image.open(io.BytesIO(buf.getvalue()))
    # quad at x = 1 filling the view; z = -1.5 is the camera's left at yaw 0, so u = 0 there
    v = np.array([[1, 0, -1.5], [1, 0, 1.5], [1, 2, 1.5], [1, 2, -1.5]], float)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    material = trimesh.visual.material.PBRMaterial(baseColorTexture=image, baseColorFactor=[255] * 4)
    mesh = trimesh.Trimesh(v, [[0, 2, 1], [0, 3, 2]], process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, material=material))
    path = tmp_path / f"quad_{fmt}.glb"
    mesh.export(path)
    with make_renderer(load_scene(path), CameraConfig(width=32, height=32, h_camera=1.0), backend) as r:
        rgb, _ = r.render([0.0, 0.0, 0.0], 0.0)
    left, right = rgb[16, 4].astype(int), rgb[16, 27].astype(int)
    assert left[0] > 100 and left[0] > 3 * max(left[1], left[2]), left
    assert right[2] > 100 and right[2] > 3 * max(right[0], right[1]), right


@pytest.mark.parametrize("backend", BACKENDS)
def test_unusable_texture_warns_and_renders_base_colour(backend, caplog):
    part = Part("poster", [[2, 0, -1], [2, 0, 1], [2, 2, 1], [2, 2, -1]], [[0, 1, 2], [0, 2, 3]],
                base_color=(0.0, 1.0, 0.0, 1.0), texture=np.zeros((4, 4, 3), np.uint8))  # no UVs
    with caplog.at_level(logging.WARNING, logger="rvn"):
        with make_renderer(Scene("test:poster", [part]), CameraConfig(width=16, height=16), backend) as r:
            rgb, _ = r.render([0.0, 0.0, 0.0], 0.0)
    assert "'poster'" in caplog.text and "base colour" in caplog.text
    assert rgb[8, 8, 1] > 100 and rgb[8, 8, [0, 2]].max() == 0


# ---- auto -------------------------------------------------------------------------------
def test_auto_picks_and_reports(monkeypatch, caplog):
    import rvn_data.render as render
    from rvn_data.render import gl

    room, cam = coloured_room(), CameraConfig(width=16, height=16)
    with caplog.at_level(logging.INFO, logger="rvn"), make_renderer(room, cam) as r:
        expected = "raycast" if egl_error() else "gl"
        assert r.backend == expected and r.reason.startswith("auto") and r.info
    assert f"test:room: {expected}" in caplog.text
    if egl_error() is None:
        ctx = gl.create_context(0)
        software = gl.is_software(gl.renderer_name(ctx))
        ctx.release()
        monkeypatch.setattr(render, "SOFTWARE_GL_MAX_TRIANGLES", 10)  # the room has 60
        with make_renderer(room, cam) as r:
            assert r.backend == ("raycast" if software else "gl")
            assert ("60 triangles > 10" in r.reason) == software

    import moderngl

    monkeypatch.setattr(gl, "_SHARED", {})  # no context made yet in this process (an earlier test may keep one)
    real = moderngl.create_standalone_context  # as on a machine without libEGL:
    monkeypatch.setattr(moderngl, "create_standalone_context",
                        lambda **kw: real(**kw, libegl="libEGL_missing_for_test.so.1"))
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="rvn"), make_renderer(room, cam) as r:
        assert r.backend == "raycast" and "no EGL" in r.reason
    assert "libegl1 libgl1-mesa-dri libegl-mesa0" in caplog.text and "raycast" in caplog.text
    with pytest.raises(RuntimeError, match="libegl1"):
        make_renderer(room, cam, backend="gl")


# ---- views and workers --------------------------------------------------------------------
def test_write_views(tmp_path):
    from rvn_data.render.views import write_views
    from rvn_data.scenes.procedural import make_apartment

    paths = write_views(make_apartment("train", 1), tmp_path / "v", n=2, seed=3, backend="raycast",
                        camera=CameraConfig(width=48, height=32))
    assert [p.name for p in paths] == ["view_00_rgb.png", "view_00_depth.png", "view_01_rgb.png",
                                       "view_01_depth.png"]
    for p in paths:
        assert np.asarray(Image.open(p)).shape == (32, 48, 3)
    meta = json.loads((tmp_path / "v" / "views.json").read_text())
    assert meta["scene"] == "procedural:train/1" and len(meta["poses"]) == 2
    with pytest.raises(ValueError, match="number of views"):
        write_views(coloured_room(), tmp_path / "w", n=0)


def test_render_parallel_matches_single_process():
    from rvn_data.render.parallel import render_parallel

    room, cam = coloured_room(), CameraConfig(width=24, height=24)
    poses = [([0.2, 0.0, -0.3], y) for y in (0.0, 1.0, 2.0, -2.5)]
    out = render_parallel(room, cam, poses, backend="raycast", processes=2)
    assert out.rgb.shape == (4, 24, 24, 3) and out.frames == 4 and out.frames_per_second > 0
    with make_renderer(room, cam, "raycast") as r:
        for i, (p, y) in enumerate(poses):
            rgb, depth = r.render(p, y)
            assert np.array_equal(rgb, out.rgb[i]) and np.array_equal(depth, out.depth[i])
