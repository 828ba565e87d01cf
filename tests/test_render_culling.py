"""The gl back-end's per-view CPU work: chunk culling (numba) against a numpy reference, the camera
pose in plain floats against numpy's array arithmetic, and the uniforms `GLRenderer._draw` writes."""
from __future__ import annotations

import math

import numpy as np

from rvn_data.conventions import heading
from rvn_data.render import CameraConfig
from rvn_data.render.chunks import build_chunks, visible_runs

from render_helpers import coloured_room, needs_egl


def numpy_runs(chunks, mvp) -> list[list[int]]:
    """Straightforward numpy culling: Gribb-Hartmann planes, sphere test, runs of adjacent chunks."""
    m = np.asarray(mvp, dtype=np.float64)
    planes = np.stack([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]])
    planes = planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
    dist = chunks.centre @ planes[:, :3].T + planes[:, 3]
    idx = np.flatnonzero(np.all(dist >= -chunks.radius[:, None], axis=1))
    runs = []
    for k in idx:
        part, first, count = int(chunks.part[k]), int(chunks.first[k]), int(chunks.count[k])
        if runs and runs[-1][3] == k - 1 and runs[-1][0] == part:
            runs[-1][2], runs[-1][3] = first + count - runs[-1][1], k
        else:
            runs.append([part, first, count, k])
    return [r[:3] for r in runs]


def random_chunks(rng):
    """3-6 parts of 1-40 chunks on a 12 m square, with spheres of 0.1-2 m."""
    spans = []
    for _ in range(rng.integers(3, 7)):
        n = rng.integers(1, 40, size=rng.integers(1, 41))
        f0 = np.r_[0, np.cumsum(n)[:-1]]
        spans.append([(int(f), int(k), rng.uniform([-6, 0, -6], [6, 3, 6]), float(rng.uniform(0.1, 2.0)))
                      for f, k in zip(f0, n)])
    return build_chunks(spans)


def test_visible_runs_equal_a_numpy_reference_on_random_frusta():
    rng = np.random.default_rng(0)
    merged = partial = empty = 0
    for _ in range(400):
        chunks = random_chunks(rng)
        cam = CameraConfig(width=int(rng.integers(8, 64)), height=int(rng.integers(8, 64)),
                           hfov_deg=float(rng.uniform(30, 150)), pitch_deg=float(rng.uniform(-60, 60)),
                           near=0.05, far=float(rng.uniform(2, 30)))
        mvp = cam.projection_matrix(flip_y=bool(rng.integers(2))) @ cam.view_matrix(
            rng.uniform([-8, -1, -8], [8, 2, 8]), float(rng.uniform(-4, 4)))
        runs, want = visible_runs(chunks, mvp), numpy_runs(chunks, mvp)
        assert runs == want
        drawn = sum(c for _, _, c in runs)
        merged += sum(c > chunks.count[(chunks.part == i) & (chunks.first == f)][0] for i, f, c in runs)
        partial += 0 < drawn < chunks.count.sum()
        empty += not runs
    assert merged > 100 and partial > 100 and empty > 10  # the frusta cover all the cases


def test_pose_equals_numpy_array_arithmetic_bit_for_bit():
    rng = np.random.default_rng(1)
    up = np.array([0.0, 1.0, 0.0])
    yaws = [0.0, -0.0, math.pi, -math.pi / 2, 1e-300, 7] + rng.uniform(-7, 7, 200).tolist()
    for k, yaw in enumerate(yaws):
        cam = CameraConfig(pitch_deg=[0.0, -0.0, 15.5, -89.0][k % 4] if k < 60 else float(rng.uniform(-89, 89)),
                           h_camera=[0.6, 1, 0.0][k % 3], forward_offset=[0.0, -0.0, 0.21, -3][k % 4])
        position = [np.zeros(3), rng.normal(size=3).astype(np.float32), rng.normal(size=3).tolist()][k % 3]
        h, p = heading(float(yaw)), math.radians(cam.pitch_deg)
        right = np.array([math.sin(yaw), 0.0, math.cos(yaw)])
        forward = math.cos(p) * h + math.sin(p) * up
        cam_up = -math.sin(p) * h + math.cos(p) * up
        eye = np.asarray(position, dtype=np.float64).reshape(3) + cam.h_camera * up + cam.forward_offset * h
        rot = np.stack([right, cam_up, -forward], axis=1)
        got_eye, got_rot = cam.pose(position, yaw)
        assert got_eye.tobytes() == eye.tobytes() and got_rot.tobytes() == rot.tobytes()
        assert got_rot.flags.c_contiguous and got_rot.dtype == np.float64


@needs_egl
def test_gl_draw_writes_the_camera_matrices_and_the_parts_colours():
    from rvn_data.render import base, gl

    cam = CameraConfig(width=16, height=12, pitch_deg=-7.0, cx=7.2)
    r = gl.GLRenderer(coloured_room(), cam)
    rng = np.random.default_rng(2)
    try:
        with r.ctx:
            for _ in range(50):
                position, yaw = rng.uniform(-1.5, 1.5, 3), float(rng.uniform(-4, 4))
                r._draw(position, yaw)
                mvp = cam.projection_matrix(flip_y=True) @ cam.view_matrix(position, yaw)
                eye, rot = cam.pose(position, yaw)
                assert r.prog["mvp"].read() == mvp.T.astype("f4").tobytes()
                assert r.prog["eye"].read() == eye.astype("f4").tobytes()
                assert r.prog["axis"].read() == (-rot[:, 2]).astype("f4").tobytes()
                part = r.scene.parts[visible_runs(r.chunks, mvp)[-1][0]]  # the last part drawn
                mat = base.prepare_material(r.scene, part)
                assert r.prog["base_rgb"].read() == mat.base_rgb.astype("f4").tobytes()
                assert r.prog["use_tex"].value == (mat.texture is not None)
    finally:
        r.close()
