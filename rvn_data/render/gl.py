"""Back-end `gl`: moderngl on a headless EGL context (NVIDIA GPU or Mesa llvmpipe), one per process and
device, shared by the renderers of every scene the process keeps (`shared_context`).

One vertex buffer per part, unindexed (three vertices per face, carrying the face's
`base.face_shade`), with faces grouped in spatial chunks that are frustum-culled per frame;
NEAREST/REPEAT textures; one reused framebuffer: RGBA8 colour and float32 planar depth
written by the fragment shader (exact, no depth-buffer linearisation).

`render_batch` draws each view into that same framebuffer and has the GPU copy it into one
staging buffer (pixel-pack, no wait), then reads the buffer once: one CPU-GPU synchronisation
per batch instead of one per view, and images byte-identical to `render`'s. Tiles of one large
framebuffer (viewport offsets) were tried and rejected: the offset window coordinates change
rasterisation and depth interpolation (llvmpipe: 1,918 of 2.1 M pixels' colours and half the
depths differed), and moderngl has no layered depth attachment for array targets.
"""
from __future__ import annotations

import struct

import numpy as np

from rvn_data.render import base
from rvn_data.render.camera import CameraConfig
from rvn_data.render.chunks import visible_runs
from rvn_data.render.mesh_arrays import MeshArrays, mesh_arrays
from rvn_data.scenes.scene import Scene

EGL_PACKAGES = "libegl1 libgl1-mesa-dri libegl-mesa0"
SOFTWARE_NAMES = ("llvmpipe", "softpipe", "swrast", "software")
STAGING_BYTES = 64 << 20  # render_batch's staging buffer: views per pass = this / (H x W x 7 bytes)

_VERTEX = """
#version 330
uniform mat4 mvp;
uniform vec3 eye;
uniform vec3 axis;  // camera forward axis (world)
in vec3 in_pos;
in vec2 in_uv;
in vec4 in_col;
in float in_shade;
out vec2 v_uv;
out vec3 v_col;
out float v_depth;
void main() {
    gl_Position = mvp * vec4(in_pos, 1.0);
    v_uv = in_uv;
    v_col = in_col.rgb * in_shade;
    v_depth = dot(in_pos - eye, axis);  // planar depth, linear in the triangle
}
"""

_FRAGMENT = """
#version 330
uniform vec3 base_rgb;
uniform bool use_tex;
uniform sampler2D tex;
in vec2 v_uv;
in vec3 v_col;
in float v_depth;
layout(location = 0) out vec4 f_rgb;
layout(location = 1) out float f_depth;
void main() {
    vec3 c = base_rgb * v_col;
    if (use_tex) c *= texture(tex, v_uv).rgb;
    f_rgb = vec4(clamp(c, 0.0, 1.0), 1.0);
    f_depth = v_depth;
}
"""


def is_software(renderer_name: str) -> bool:
    """True for CPU rasterisers (llvmpipe, softpipe, swrast)."""
    name = renderer_name.lower()
    return any(s in name for s in SOFTWARE_NAMES)


def create_context(device: int = 0):
    """A headless EGL moderngl context on EGL device `device`; RuntimeError if impossible."""
    try:
        import moderngl
    except ImportError as e:  # pragma: no cover - moderngl is a hard dependency
        raise RuntimeError(f"renderer backend 'gl' needs the Python package moderngl ({e})") from e
    try:
        ctx = moderngl.create_standalone_context(backend="egl", device_index=int(device))
    except Exception as e:  # glcontext raises bare Exceptions
        if "device index" in str(e):
            raise RuntimeError(f"renderer backend 'gl': EGL device {device} does not exist ({e}); "
                               "set renderer.device to an index below the device count") from e
        raise RuntimeError(
            f"renderer backend 'gl': no headless EGL OpenGL context on device {device} ({e}). "
            f"Install the system libraries {EGL_PACKAGES} (apt-get install -y {EGL_PACKAGES}; "
            "NVIDIA drivers ship EGL on GPU nodes) or use renderer backend=raycast.") from e
    if ctx.version_code < 330:
        ctx.release()
        raise RuntimeError(f"renderer backend 'gl' needs OpenGL >= 3.3, EGL device {device} gives {ctx.version_code}")
    return ctx


_SHARED: dict[int, list] = {}  # EGL device -> [context, renderers using it]


def shared_context(device: int = 0):
    """This process's EGL context on ``device``, made at its first use and shared by the GL renderers of every
    scene the process renders (an RL or rvn-eval worker keeps several): one context, so the GPU does not switch
    contexts between scenes and software GL keeps one thread pool. Each call takes a reference that
    :func:`release_context` gives back; the last one releases the context."""
    entry = _SHARED.get(device)
    if entry is None:
        entry = _SHARED[device] = [create_context(device), 0]
    entry[1] += 1
    return entry[0]


def release_context(ctx) -> None:
    """Gives back a reference taken by :func:`shared_context` (a context not shared is released)."""
    for device, entry in _SHARED.items():
        if entry[0] is ctx:
            entry[1] -= 1
            if entry[1] == 0:
                del _SHARED[device]
                ctx.release()
            return
    ctx.release()


def renderer_name(ctx) -> str:
    """The GL_RENDERER string, e.g. 'llvmpipe (LLVM 15.0.6, 256 bits)' or a GPU name."""
    return str(ctx.info.get("GL_RENDERER", "unknown"))


class GLRenderer(base.Renderer):
    """Rasterises the scene with OpenGL 3.3 on EGL; `info` names the GL renderer. It draws in the process's
    shared context (:func:`shared_context`) unless given ``ctx``, which it then owns; every draw sets the state
    it uses (framebuffer, program, uniforms, texture), so renderers sharing a context give the same images."""

    backend = "gl"

    def __init__(self, scene: Scene, camera: CameraConfig, device: int = 0, ctx=None,
                 arrays: "MeshArrays | None" = None) -> None:
        """``arrays``: the scene's `mesh_arrays`, made ahead (in a helper process or thread), else made here."""
        super().__init__(scene, camera)
        base.check_scene(scene)
        import moderngl

        self.ctx = ctx if ctx is not None else shared_context(device)
        name = renderer_name(self.ctx)
        kind = "software" if is_software(name) else "GPU"
        self.info = f"{name} ({kind}, EGL device {device})"
        self.software = kind == "software"
        self._mgl = moderngl
        self._objects = []
        self._staging = None  # render_batch's pixel-pack buffer, grown on demand
        self.batch_views = max(1, STAGING_BYTES // (camera.width * camera.height * 7))
        try:
            with self.ctx:  # make it current: other renderers may own other contexts
                self._build(scene, camera, arrays)
        except Exception:
            self.close()
            raise

    def _build(self, scene: Scene, camera: CameraConfig, arrays: "MeshArrays | None") -> None:
        ctx, mgl = self.ctx, self._mgl
        self.prog = self._keep(ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT))
        self._set("tex", 0)
        self._uniforms = tuple(self.prog[name] for name in ("mvp", "eye", "axis", "base_rgb", "use_tex"))
        self._part_uniforms_now = None  # (base_rgb, use_tex) bytes in the program: only _draw writes them
        self._view = np.eye(4)  # _draw's view matrix: rows 0-2 rewritten per view
        self.parts = []
        arrays = mesh_arrays(scene) if arrays is None else arrays
        for part in arrays.parts:
            if part is None:
                self.parts.append(None)
                continue
            data, texture, uniforms = part
            vbo = self._keep(ctx.buffer(data))
            vao = self._keep(ctx.vertex_array(
                self.prog, [(vbo, "3f 2f 4f1 1f", "in_pos", "in_uv", "in_col", "in_shade")]))
            tex = None
            if texture is not None:
                h, w = texture.shape[:2]
                tex = self._keep(ctx.texture((w, h), 3, texture))
                tex.filter = (mgl.NEAREST, mgl.NEAREST)
                tex.repeat_x = tex.repeat_y = True
            self.parts.append((vao, tex, uniforms))
        self.chunks = arrays.chunks
        size = (camera.width, camera.height)
        self.fbo = self._keep(ctx.framebuffer(
            color_attachments=[self._keep(ctx.renderbuffer(size, 4)),
                               self._keep(ctx.renderbuffer(size, 1, dtype="f4"))],
            depth_attachment=self._keep(ctx.depth_renderbuffer(size))))
        self.proj = camera.projection_matrix(flip_y=True)  # read-back is then top row first

    def _set(self, name: str, value) -> None:
        if name in self.prog:  # the GLSL compiler may drop unused uniforms
            self.prog[name].value = value

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def render(self, position, yaw: float, depth: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        if self.ctx is None:
            raise RuntimeError("render() on a closed GL renderer")
        with self.ctx:  # current for this frame, previous context restored after
            return self._render(position, yaw, depth)

    def _render(self, position, yaw: float, with_depth: bool) -> tuple[np.ndarray, np.ndarray | None]:
        cam = self.camera
        self._draw(position, yaw)
        rgb = np.empty((cam.height, cam.width, 3), np.uint8)
        self.fbo.read_into(rgb, components=3, attachment=0)
        if not with_depth:  # the second read-back costs about as much as the first
            return rgb, None
        depth = np.empty((cam.height, cam.width), np.float32)
        self.fbo.read_into(depth, components=1, attachment=1, dtype="f4")
        return rgb, depth

    def _draw(self, position, yaw: float) -> None:
        """Clear the framebuffer and draw the view from (position, yaw) into it. The matrices are
        computed as ``proj @ view_matrix`` (the same numpy operations, so the same bits); uniforms
        are written as packed bytes, and a part's base colour and texture flag only when they differ
        from what this renderer's program holds."""
        eye, rot = self.camera.pose(position, yaw)
        view = self._view
        view[:3, :3] = rot.T
        view[:3, 3] = -rot.T @ eye
        mvp = self.proj @ view
        self.fbo.use()
        self.ctx.enable_only(self._mgl.DEPTH_TEST)
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        u_mvp, u_eye, u_axis, u_rgb, u_tex = self._uniforms
        u_mvp.write(mvp.T.astype("f4").tobytes())
        u_eye.write(struct.pack("3f", *eye.tolist()))
        u_axis.write(struct.pack("3f", *(-rot[:, 2]).tolist()))  # camera forward
        parts, triangles, current = self.parts, self._mgl.TRIANGLES, -1
        for i, first, count in visible_runs(self.chunks, mvp):
            if i != current:
                vao, tex, uniforms = parts[i]
                now = self._part_uniforms_now
                if now is None or uniforms[0] != now[0]:
                    u_rgb.write(uniforms[0])
                if now is None or uniforms[1] != now[1]:
                    u_tex.write(uniforms[1])
                self._part_uniforms_now = uniforms
                if tex is not None:
                    tex.use(0)
                current = i
            vao.render(triangles, vertices=count, first=first)

    def pass_group(self) -> object:
        """GL renderers of one context and camera size draw their views in one pass (`base.render_views`)."""
        return ("gl", id(self.ctx), self.camera.width, self.camera.height)

    def _render_pass(self, views: list, rgb: np.ndarray, depth: np.ndarray | None) -> None:
        """Draw each view [(renderer, position, yaw)] with its renderer (one context), copy it on the
        GPU into this renderer's staging buffer (depths of all views, then colours: a float read into
        a buffer must start at a multiple of 4 bytes, which n colour images of W x H x 3 bytes need
        not end at), and read the buffer back once."""
        if any(renderer.ctx is None for renderer, _, _ in views):
            raise RuntimeError("render_batch() on a closed GL renderer")
        n, cam = len(views), self.camera
        rgb_bytes, depth_bytes = cam.width * cam.height * 3, cam.width * cam.height * 4
        rgb_at = n * depth_bytes if depth is not None else 0
        with self.ctx:
            staging = self._staging_buffer(rgb_at + n * rgb_bytes)
            for k, (renderer, position, yaw) in enumerate(views):
                renderer._draw(position, yaw)
                if depth is not None:
                    renderer.fbo.read_into(staging, components=1, attachment=1, dtype="f4", write_offset=k * depth_bytes)
                renderer.fbo.read_into(staging, components=3, attachment=0, write_offset=rgb_at + k * rgb_bytes)
            staging.read_into(rgb, size=n * rgb_bytes, offset=rgb_at)  # waits for the GPU once
            if depth is not None:
                staging.read_into(depth, size=n * depth_bytes)

    def _staging_buffer(self, size: int):
        if self._staging is None or self._staging.size < size:
            if self._staging is not None:
                self._staging.release()
            self._staging = None
            self._staging = self.ctx.buffer(reserve=size)
        return self._staging

    def close(self) -> None:
        if getattr(self, "ctx", None) is None:
            return
        with self.ctx:
            for obj in reversed(self._objects):
                obj.release()
            if self._staging is not None:
                self._staging.release()
        self._objects.clear()
        self._staging = None
        self.parts = []
        release_context(self.ctx)
        self.ctx = None
