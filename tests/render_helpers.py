"""Helpers of the renderer tests (test_render.py, test_render_batch.py): whether the gl back-end
can run here, a coloured room with a textured floor, navigable poses. Not in conftest.py so that
only these tests create a GL context at import."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest
import trimesh

from rvn_data.scenes import Part, Scene


@lru_cache(maxsize=1)
def egl_error() -> str | None:
    from rvn_data.render import gl

    try:
        gl.create_context(0).release()
    except RuntimeError as e:
        return str(e)
    return None


needs_egl = pytest.mark.skipif(egl_error() is not None, reason=f"gl back-end unavailable: {egl_error()}")
BACKENDS = [pytest.param("gl", marks=needs_egl), "raycast"]


def box(name, lo, hi, color=(0.7, 0.7, 0.7, 1.0), texture=None) -> Part:
    b = trimesh.creation.box(bounds=[lo, hi])
    uv = b.vertices[:, [0, 2]] if texture is not None else None
    return Part(name, b.vertices, b.faces, uv=uv, base_color=color, texture=texture)


def coloured_room() -> Scene:
    """4 x 4 m room: north (-z) red, east (+x) blue, south green, west yellow, checker floor."""
    checker = np.zeros((8, 8, 3), np.uint8)
    checker[::2, ::2] = checker[1::2, 1::2] = 255
    return Scene("test:room", [
        box("floor", [-2, -0.1, -2], [2, 0, 2], (1, 1, 1, 1), checker),
        box("north", [-2, 0, -2.1], [2, 2.5, -2], (1, 0, 0, 1)),
        box("south", [-2, 0, 2], [2, 2.5, 2.1], (0, 1, 0, 1)),
        box("east", [2, 0, -2], [2.1, 2.5, 2], (0, 0, 1, 1)),
        box("west", [-2.1, 0, -2], [-2, 2.5, 2], (1, 1, 0, 1))])


def navigable_poses(scene: Scene, n: int, seed: int = 0):
    from rvn_data.navmesh import NavMesh, NavMeshSettings

    nm = NavMesh.build(scene, NavMeshSettings())
    rng = np.random.default_rng(seed)
    return [(nm.sample(rng), float(rng.uniform(-math.pi, math.pi))) for _ in range(n)]
