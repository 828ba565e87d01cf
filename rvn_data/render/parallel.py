"""Render many poses in N worker processes, each with its own renderer.

embreex holds the GIL and software GL shares one process's threads, so throughput comes
from processes. Workers start with the `spawn` (default) or `forkserver` context, build
their renderer, wait at a barrier, then render their share of the poses; the reported
time runs from the first worker's start to the last worker's end. With ``batch`` > 1 a
worker renders ``batch`` poses per `Renderer.render_batch` call instead of one per `render`.
"""
from __future__ import annotations

import queue
import time
from dataclasses import dataclass

import numpy as np

from rvn_data.render.camera import CameraConfig


@dataclass
class ParallelRenders:
    """Result of `render_parallel`: images in pose order (None unless asked) and timing."""

    rgb: np.ndarray | None  # uint8 [N, H, W, 3]
    depth: np.ndarray | None  # float32 [N, H, W]
    frames: int
    seconds: float  # wall time of the rendering itself (set-up excluded)
    cpu_seconds: float  # CPU time of all workers' processes while rendering
    processes: int
    backend: str  # what the workers' renderers picked
    batch: int = 1  # poses per render call

    @property
    def frames_per_second(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    @property
    def cpu_share(self) -> float:
        """CPU time / (wall time x processes): below 1 when other load competed for the cores."""
        return self.cpu_seconds / (self.seconds * self.processes) if self.seconds > 0 else 0.0


def _next(renderer, poses, done: int, batch: int) -> tuple:
    """The next frames after ``done``: one `render`, or `render_batch` of ``batch`` poses (cycling)."""
    if batch == 1:
        rgb, depth = renderer.render(*poses[done % len(poses)])
        return rgb[None], depth[None]
    return renderer.render_batch([poses[(done + i) % len(poses)] for i in range(batch)])


def _worker(rank, scene, camera, backend, device, poses, keep, barrier, results, seconds=None, batch=1) -> None:
    try:
        from rvn_data.render import make_renderer

        if isinstance(scene, str):
            from rvn_data.scenes.loader import load_scene

            scene = load_scene(scene)
        with make_renderer(scene, camera, backend=backend, device=device) as renderer:
            if len(poses):
                _next(renderer, poses, 0, min(batch, len(poses)))  # warm-up: numba / GL pipelines
            barrier.wait()
            t0, c0 = time.monotonic(), time.process_time()
            out, frames = [], 0
            while poses and (frames < len(poses) if seconds is None else time.monotonic() - t0 < seconds):
                n = min(batch, len(poses) - frames) if seconds is None else batch
                frame = _next(renderer, poses, frames, n)
                frames += n
                if keep:
                    out.append(frame)
            t1, cpu = time.monotonic(), time.process_time() - c0
            picked = renderer.backend
        rgb = np.concatenate([o[0] for o in out]) if keep and out else None
        depth = np.concatenate([o[1] for o in out]) if keep and out else None
        results.put(dict(rank=rank, t0=t0, t1=t1, cpu=cpu, backend=picked, rgb=rgb, depth=depth, frames=frames,
                         error=None))
    except BaseException as e:  # report to the parent instead of hanging it
        barrier.abort()
        results.put(dict(rank=rank, error=f"{type(e).__name__}: {e}"))


def render_parallel(scene, camera: CameraConfig, poses, backend: str = "raycast", processes: int = 2,
                    device: int = 0, return_images: bool = True, start_method: str = "spawn",
                    seconds: float | None = None, batch: int = 1) -> ParallelRenders:
    """Render `poses` [(position[3], yaw), ...] split over `processes` workers.

    `scene` is a `Scene` (pickled to the workers) or a scene spec for `load_scene`. With
    `seconds`, each worker renders its share over and over for that long instead of once
    (a throughput figure: images are not kept, `frames` counts what was rendered). ``batch``:
    poses per render call (`Renderer.render_batch` when > 1; the same images).
    """
    import multiprocessing as mp

    if seconds is not None:
        if not seconds > 0:
            raise ValueError(f"seconds={seconds!r} must be positive")
        return_images = False
    if processes < 1:
        raise ValueError(f"processes={processes!r} must be >= 1")
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch={batch!r} must be a positive integer (poses per render call)")
    if start_method not in ("spawn", "forkserver"):
        raise ValueError(f"start_method={start_method!r} must be 'spawn' or 'forkserver' (fork breaks GL/numba)")
    poses = [(np.asarray(p, np.float64), float(y)) for p, y in poses]
    ctx = mp.get_context(start_method)
    barrier, results = ctx.Barrier(processes), ctx.Queue()
    shares = np.array_split(np.arange(len(poses)), processes)
    procs = [ctx.Process(target=_worker, daemon=True,
                         args=(r, scene, camera, backend, device, [poses[i] for i in idx], return_images,
                               barrier, results, seconds, batch))
             for r, idx in enumerate(shares)]
    for p in procs:
        p.start()
    got = {}
    try:
        while len(got) < processes:
            try:
                item = results.get(timeout=1.0)
            except queue.Empty:  # a worker that died without reporting (killed, crashed)
                dead = [r for r, p in enumerate(procs) if r not in got and p.exitcode not in (None, 0)]
                if dead:
                    raise RuntimeError(f"render worker {dead[0]} died (exit code {procs[dead[0]].exitcode})")
                continue
            got[item["rank"]] = item
    finally:
        for p in procs:
            p.join(timeout=30)
            if p.is_alive():
                p.terminate()
    errors = [g["error"] for g in got.values() if g["error"]]
    if errors:
        raise RuntimeError(f"render worker failed: {errors[0]}")
    wall = max(g["t1"] for g in got.values()) - min(g["t0"] for g in got.values())
    rgb = depth = None
    if return_images and poses:
        rgb = np.concatenate([got[r]["rgb"] for r in range(processes) if got[r]["rgb"] is not None])
        depth = np.concatenate([got[r]["depth"] for r in range(processes) if got[r]["depth"] is not None])
    cpu = sum(g["cpu"] for g in got.values())
    frames = sum(g["frames"] for g in got.values())
    return ParallelRenders(rgb, depth, frames, wall, cpu, processes, got[0]["backend"], batch)
