"""RGB and planar depth from the robot's camera: back-ends `gl` (EGL) and `raycast` (embree).

`make_renderer(scene, camera, backend="auto")` is the entry point; `auto` picks GL when an
EGL context can be created and either a GPU is present or the mesh is small enough for
software GL (<= SOFTWARE_GL_MAX_TRIANGLES), otherwise raycast, and says why in
`renderer.reason` and the 'rvn' log.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from rvn_data.render.base import Renderer, check_scene, log, render_views
from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.scene import Scene

BACKENDS = ("auto", "gl", "raycast")
SOFTWARE_GL_MAX_TRIANGLES = 300_000

__all__ = ["BACKENDS", "CameraConfig", "Renderer", "RendererConfig", "SOFTWARE_GL_MAX_TRIANGLES", "make_renderer",
           "render_views"]


@dataclass(frozen=True)
class RendererConfig:
    """Renderer back-end request (conf/renderer/*.yaml; rvn_data.render.make_renderer)."""

    backend: str = "auto"  # auto | gl | raycast
    device: int = 0  # EGL device index for gl (GPU on multi-GPU nodes)


def _camera(camera) -> CameraConfig:
    if camera is None:
        return CameraConfig()
    if isinstance(camera, CameraConfig):
        return camera
    if isinstance(camera, Mapping) or hasattr(camera, "items"):
        return CameraConfig.from_dict(camera)
    raise ValueError(f"camera must be a CameraConfig or a mapping of camera settings, got {type(camera).__name__}")


def make_renderer(scene: Scene, camera: CameraConfig | Mapping | None = None, backend: str = "auto",
                  device: int = 0, gl_arrays=None) -> Renderer:
    """A renderer for `scene`; `backend` is 'auto', 'gl' or 'raycast', `device` the EGL device; ``gl_arrays``: the
    scene's `mesh_arrays` made ahead, which a gl renderer uploads instead of making them."""
    camera = _camera(camera)
    backend = str(backend).lower()
    if backend not in BACKENDS:
        raise ValueError(f"renderer backend={backend!r} is not one of {list(BACKENDS)}")
    if isinstance(device, bool) or not isinstance(device, int) or device < 0:
        raise ValueError(f"renderer device={device!r} must be a non-negative integer (EGL device index)")
    check_scene(scene)
    from rvn_data.render.raycast import RaycastRenderer

    if backend == "raycast":
        return _picked(RaycastRenderer(scene, camera), "requested backend=raycast")
    from rvn_data.render import gl

    if backend == "gl":
        return _picked(gl.GLRenderer(scene, camera, device=device, arrays=gl_arrays), "requested backend=gl")
    try:
        ctx = gl.shared_context(device)
    except RuntimeError as e:
        log.warning("renderer auto: %s Falling back to the raycast back-end.", e)
        return _picked(RaycastRenderer(scene, camera), "auto: no EGL context, raycast fallback")
    name = gl.renderer_name(ctx)
    n = scene.num_triangles
    if not gl.is_software(name):
        reason = f"auto: GPU GL renderer {name!r}"
    elif n <= SOFTWARE_GL_MAX_TRIANGLES:
        reason = f"auto: software GL {name!r}, {n} triangles <= {SOFTWARE_GL_MAX_TRIANGLES}"
    else:
        gl.release_context(ctx)
        return _picked(RaycastRenderer(scene, camera),
                       f"auto: software GL {name!r} only and {n} triangles > {SOFTWARE_GL_MAX_TRIANGLES}")
    try:
        renderer = gl.GLRenderer(scene, camera, device=device, ctx=ctx, arrays=gl_arrays)
    except Exception as e:  # moderngl.Error, RuntimeError: a broken GL stack
        log.warning("renderer auto: GL set-up failed (%s); falling back to the raycast back-end.", e)
        return _picked(RaycastRenderer(scene, camera), f"auto: GL set-up failed ({e}), raycast fallback")
    return _picked(renderer, reason)


def _picked(renderer: Renderer, reason: str) -> Renderer:
    renderer.reason = reason
    log.info("renderer for %s: %s [%s] (%s)", renderer.scene.scene_id, renderer.backend, renderer.info, reason)
    return renderer
