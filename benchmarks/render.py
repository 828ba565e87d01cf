"""Renderer figures (issue 3): frames/s per process at 256² for the `gl` and `raycast`
back-ends on a procedural apartment and on dream_apartment, and combined frames/s with
2 worker processes (ratio vs one).

Poses are navigable points from the scene's navmesh with random yaws (fixed seed). Each
figure comes from `rvn_data.render.parallel.render_parallel`: workers build their
renderer, render one warm-up frame, wait for each other, then render their share; the
time runs from the first start to the last end. Software GL (llvmpipe) already uses every
core in one process, so its 2-process ratio says little; raycast is single-threaded.
"cpu share" = worker CPU time / (wall time x processes): for raycast, below 1 means other
load on the machine took the cores (llvmpipe's threads can exceed 1).
"batch B": one renderer in this process rendering B views per `Renderer.render_batch` call (the
same images; gl syncs with the GPU once per batch) against one view per `render` call, the two
timed in alternation over --rounds rounds of the same poses (medians; on a shared machine the
alternation keeps other load from favouring either); "cpu ms/frame" counts all of its threads.
"at 8x8" (--small): the same with the largest batch and a camera of --small² pixels, where rasterising
costs next to nothing: what is left is each view's CPU work around it (pose, matrices, culling, uniforms,
draw calls), the cap on frames/s on a fast GPU; llvmpipe also transforms the vertices there on the CPU.
Goals (2-core CPU): gl >= 280 frames/s on a procedural scene; raycast >= 80 frames/s on
dream_apartment; 2 processes >= 1.7 x one.
Run: python benchmarks/render.py [--frames 300] [--size 256] [--batch 8 32] [--rounds 5] [--small 8]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

DREAM = Path(__file__).resolve().parents[2] / "shared" / "scenes" / "dream_apartment.glb"


def poses_for(scene, n: int, seed: int = 0):
    from rvn_data.navmesh import NavMesh, NavMeshSettings

    nm = NavMesh.build(scene, NavMeshSettings())
    rng = np.random.default_rng([seed, 3])
    return [(nm.sample(rng), float(rng.uniform(-math.pi, math.pi))) for _ in range(n)]


def timed(fn, frames: int) -> tuple[float, float]:
    """(frames/s wall, CPU ms per frame) of one call of ``fn``."""
    t, c = time.perf_counter(), time.process_time()
    fn()
    return frames / (time.perf_counter() - t), 1e3 * (time.process_time() - c) / frames


def batch_figures(renderer, poses, batch: int, rounds: int) -> dict:
    """Median frames/s and CPU ms/frame of one view per `render` call and of ``batch`` views per
    `render_batch` call, timed in alternation over ``rounds`` rounds of ``poses``."""
    groups = [poses[k:k + batch] for k in range(0, len(poses), batch)]

    def single():
        for p, y in poses:
            renderer.render(p, y)

    def batched():
        for g in groups:
            renderer.render_batch(g)

    single(), batched()  # warm-up: numba compilation, GL pipelines, staging buffers
    runs = {"single": [], "batch": []}
    for _ in range(rounds):
        runs["single"].append(timed(single, len(poses)))
        runs["batch"].append(timed(batched, len(poses)))
    return {k: tuple(float(x) for x in np.median(np.array(v), axis=0)) for k, v in runs.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=300, help="frames per measurement (split over workers)")
    ap.add_argument("--size", type=int, default=256, help="image width = height")
    ap.add_argument("--backends", nargs="+", default=["gl", "raycast"])
    ap.add_argument("--scenes", nargs="+", default=["procedural:train/0", str(DREAM)])
    ap.add_argument("--batch", nargs="*", type=int, default=[8, 32], help="views per render_batch call (1 process)")
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds of the batch figures")
    ap.add_argument("--small", type=int, default=8, help="width = height of the per-view CPU figure (0: none)")
    args = ap.parse_args()
    if any(b < 1 for b in args.batch) or args.rounds < 1 or args.small < 0:
        ap.error(f"--batch {args.batch}, --rounds {args.rounds}: must be >= 1; --small {args.small}: >= 0")

    from rvn_data.render import CameraConfig, make_renderer
    from rvn_data.render.parallel import render_parallel
    from rvn_data.scenes.loader import load_scene

    camera = CameraConfig(width=args.size, height=args.size)
    print(f"Renderer frames/s at {args.size}x{args.size} (RGB + depth), {args.frames} frames per figure "
          "(shared, noisy machine: figures as measured)")
    for spec in args.scenes:
        scene = load_scene(spec)
        poses = poses_for(scene, args.frames)
        print(f"\n{scene.scene_id}: {scene.num_triangles:,} triangles, {len(scene.parts)} parts")
        for backend in args.backends:
            try:
                with make_renderer(scene, camera, backend) as r:
                    info = r.info
            except RuntimeError as e:
                print(f"  {backend:8s}: unavailable ({e})")
                continue
            one = render_parallel(scene, camera, poses, backend, processes=1, return_images=False)
            two = render_parallel(scene, camera, poses, backend, processes=2, return_images=False)
            f1, f2 = one.frames_per_second, two.frames_per_second
            print(f"  {backend:8s}: 1 process {f1:7.1f} frames/s ({1e3 / f1:5.2f} ms/frame, cpu share "
                  f"{one.cpu_share:4.2f}) | 2 processes {f2:7.1f} frames/s combined, {f2 / f1:4.2f}x "
                  f"(cpu share {two.cpu_share:4.2f})  [{info}]")
            with make_renderer(scene, camera, backend) as r:
                for b in args.batch:
                    fig = batch_figures(r, poses[:max(b, args.frames // 4 // b * b)], b, args.rounds)
                    (fs, cs), (fb, cb) = fig["single"], fig["batch"]
                    print(f"  {backend:8s}: batch {b:3d} {fb:7.1f} frames/s (cpu {cb:5.2f} ms/frame) vs one view "
                          f"per call {fs:7.1f} frames/s (cpu {cs:5.2f} ms/frame): {fb / fs:4.2f}x")
            if args.small and args.batch:
                b = max(args.batch)
                with make_renderer(scene, CameraConfig(width=args.small, height=args.small), backend) as r:
                    fig = batch_figures(r, poses[:max(b, len(poses) // b * b)], b, args.rounds)
                (fs, cs), (fb, cb) = fig["single"], fig["batch"]
                print(f"  {backend:8s}: at {args.small}x{args.small}, batch {b:3d} {fb:8.1f} frames/s (cpu {cb:6.3f} "
                      f"ms/frame) vs one view per call {fs:8.1f} frames/s (cpu {cs:6.3f} ms/frame)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
