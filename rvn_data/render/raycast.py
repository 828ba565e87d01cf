"""Back-end `raycast`: embreex ray casting with numba shading (pip-only, CPU).

One embree triangle mesh holds every part; a hit's primitive id gives its part, the
barycentrics (u, v) interpolate UVs and vertex colours, textures are sampled NEAREST with
REPEAT wrap, and the lighting is `rvn_data.render.base`'s. Rays have a unit forward
component and start on the near plane, so near + hit distance is the planar depth and
near/far clip exactly as in GL. embreex holds the GIL: run several
processes for throughput (`rvn_data.render.parallel`). `render_batch` casts the rays of up to
`MAX_BATCH_RAYS` pixels (16 views at 256²) in one embree call and shades them in one numba pass.
"""
from __future__ import annotations

import numba
import numpy as np

from rvn_data.render import base
from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.scene import Scene

MAX_BATCH_RAYS = 1 << 20  # rays per render_batch pass: about 60 MB of ray and hit arrays


@numba.njit(cache=True, parallel=False)
def _rays(dirs_cam, rot, eye, near, far, origins, dirs, tfar):
    """World rays of this frame into preallocated arrays, starting on the near plane."""
    for i in range(dirs_cam.shape[0]):
        x, y, z = dirs_cam[i, 0], dirs_cam[i, 1], dirs_cam[i, 2]
        for j in range(3):
            d = rot[j, 0] * x + rot[j, 1] * y + rot[j, 2] * z
            dirs[i, j] = d
            origins[i, j] = eye[j] + near * d
        tfar[i] = far - near


@numba.njit(cache=True, parallel=False)
def _rays_batch(dirs_cam, rots, eyes, near, far, origins, dirs, tfar):
    """`_rays` of views k = 0..n-1 (rots [n, 3, 3], eyes [n, 3]) into rows k*P..(k+1)*P-1."""
    npx = dirs_cam.shape[0]
    for k in range(rots.shape[0]):
        a, b = k * npx, (k + 1) * npx
        _rays(dirs_cam, rots[k], eyes[k], near, far, origins[a:b], dirs[a:b], tfar[a:b])


@numba.njit(cache=True, parallel=False)
def _shade(prim, bu, bv, tfar, near, faces, face_part, face_shade, uv, col, part_rgb,
           tex_off, tex_w, tex_h, texels, rgb, depth):
    """Shade each ray's hit into rgb [N, 3] uint8 and depth [N] float32 (0 = miss)."""
    for i in range(prim.shape[0]):
        p = prim[i]
        if p < 0:
            depth[i] = 0.0
            rgb[i, 0] = 0
            rgb[i, 1] = 0
            rgb[i, 2] = 0
            continue
        depth[i] = tfar[i] + near
        part = face_part[p]
        i0, i1, i2 = faces[p, 0], faces[p, 1], faces[p, 2]
        b1, b2 = bu[i], bv[i]
        b0 = 1.0 - b1 - b2
        shade = face_shade[p]
        r = part_rgb[part, 0] * (b0 * col[i0, 0] + b1 * col[i1, 0] + b2 * col[i2, 0])
        g = part_rgb[part, 1] * (b0 * col[i0, 1] + b1 * col[i1, 1] + b2 * col[i2, 1])
        b = part_rgb[part, 2] * (b0 * col[i0, 2] + b1 * col[i1, 2] + b2 * col[i2, 2])
        if tex_off[part] >= 0:
            w, h = tex_w[part], tex_h[part]
            s = b0 * uv[i0, 0] + b1 * uv[i1, 0] + b2 * uv[i2, 0]
            t = b0 * uv[i0, 1] + b1 * uv[i1, 1] + b2 * uv[i2, 1]
            tx = min(int(np.floor((s - np.floor(s)) * w)), w - 1)
            ty = min(int(np.floor((t - np.floor(t)) * h)), h - 1)
            o = tex_off[part] + ((h - 1 - ty) * w + tx) * 3  # t = 0 is the image's bottom row
            r *= texels[o] / 255.0
            g *= texels[o + 1] / 255.0
            b *= texels[o + 2] / 255.0
        rgb[i, 0] = min(255.0, max(0.0, r * shade) * 255.0 + 0.5)
        rgb[i, 1] = min(255.0, max(0.0, g * shade) * 255.0 + 0.5)
        rgb[i, 2] = min(255.0, max(0.0, b * shade) * 255.0 + 0.5)


class RaycastRenderer(base.Renderer):
    """Ray casts the scene with embree on the CPU; one process, one thread."""

    backend = "raycast"

    def __init__(self, scene: Scene, camera: CameraConfig) -> None:
        super().__init__(scene, camera)
        base.check_scene(scene)
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        verts, faces, face_part, uv, col, part_rgb = [], [], [], [], [], []
        tex_off, tex_w, tex_h, texels = [], [], [], []
        offset, texel_count = 0, 0
        for i, part in enumerate(scene.parts):
            mat = base.prepare_material(scene, part)
            n = len(part.vertices)
            verts.append(part.vertices)
            faces.append(part.faces + offset)
            face_part.append(np.full(len(part.faces), i, np.int32))
            uv.append(part.uv if part.uv is not None else np.zeros((n, 2), np.float32))
            col.append(part.colors[:, :3] / np.float32(255.0) if part.colors is not None
                       else np.ones((n, 3), np.float32))
            part_rgb.append(mat.base_rgb)
            if mat.texture is None:
                tex_off.append(-1), tex_w.append(0), tex_h.append(0)
            else:
                h, w = mat.texture.shape[:2]
                tex_off.append(texel_count), tex_w.append(w), tex_h.append(h)
                texels.append(mat.texture.reshape(-1))
                texel_count += mat.texture.size
            offset += n
        self._verts = np.ascontiguousarray(np.concatenate(verts), np.float32)
        self._faces = np.ascontiguousarray(np.concatenate(faces), np.int32)
        self._face_part = np.concatenate(face_part)
        self._uv = np.ascontiguousarray(np.concatenate(uv), np.float32)
        self._col = np.ascontiguousarray(np.concatenate(col), np.float32)
        self._part_rgb = np.ascontiguousarray(np.stack(part_rgb), np.float32)
        self._tex_off = np.asarray(tex_off, np.int64)
        self._tex_w = np.asarray(tex_w, np.int64)
        self._tex_h = np.asarray(tex_h, np.int64)
        self._texels = np.concatenate(texels) if texels else np.zeros(3, np.uint8)
        self._face_shade = base.face_shade(self._verts, self._faces)

        self._embree = rtcore_scene.EmbreeScene()
        TriangleMesh(self._embree, self._verts, self._faces)
        npx = camera.width * camera.height
        self._dirs_cam = np.ascontiguousarray(camera.ray_directions().reshape(npx, 3), np.float32)
        self._batch_rays = None  # (origins, dirs, tfar, depth) of the views of a call, grown on demand
        self.batch_views = max(1, MAX_BATCH_RAYS // npx)
        self.info = f"embree (embreex) + numba, 1 thread, {len(self._faces)} triangles"

    def render(self, position, yaw: float, depth: bool = True) -> tuple[np.ndarray, np.ndarray]:
        if self._embree is None:  # depth comes free with the hit distances: always returned
            raise RuntimeError("render() on a closed raycast renderer")
        cam = self.camera
        rgb = np.empty((1, cam.height, cam.width, 3), np.uint8)
        depth = np.empty((1, cam.height, cam.width), np.float32)
        self._render_views([(position, yaw)], rgb, depth)
        return rgb[0], depth[0]

    def _render_views(self, poses: list, rgb: np.ndarray, depth: np.ndarray | None) -> None:
        """Rays of all views, one embree call, one shading pass, written straight into rgb/depth (`render`: one view)."""
        if self._embree is None:
            raise RuntimeError("render_batch() on a closed raycast renderer")
        cam, n = self.camera, len(poses)
        rays = n * cam.width * cam.height
        if self._batch_rays is None or len(self._batch_rays[2]) < rays:
            self._batch_rays = (np.empty((rays, 3), np.float32), np.empty((rays, 3), np.float32),
                                np.empty(rays, np.float32), np.empty(rays, np.float32))
        origins, dirs, tfar, scratch = (a[:rays] for a in self._batch_rays)
        frames = [cam.pose(position, yaw) for position, yaw in poses]
        eyes = np.stack([eye for eye, _ in frames])
        rots = np.stack([rot for _, rot in frames])
        _rays_batch(self._dirs_cam, rots, eyes, cam.near, cam.far, origins, dirs, tfar)
        self._cast(origins, dirs, tfar, rgb.reshape(rays, 3), scratch if depth is None else depth.reshape(rays))

    def _cast(self, origins, dirs, tfar, rgb, depth) -> None:
        """Intersect the rays with the scene and shade the hits into rgb [R, 3] and depth [R]."""
        hit = self._embree.run(origins, dirs, dists=tfar, output=1)
        prim = np.where(hit["geomID"] >= 0, hit["primID"], -1)
        _shade(prim, hit["u"], hit["v"], hit["tfar"], self.camera.near, self._faces, self._face_part,
               self._face_shade, self._uv, self._col, self._part_rgb, self._tex_off, self._tex_w,
               self._tex_h, self._texels, rgb, depth)

    def close(self) -> None:
        self._embree = None
        self._batch_rays = None
