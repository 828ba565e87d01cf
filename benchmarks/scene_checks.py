"""What the plausibility checks cost a mesh file's load (`rvn_data.scenes.plausibility.check_scene`: the extent, the
up axis, the floor's tilt). Prints, for each mesh, its triangles, the load's ms (`load_mesh_file`, checks included),
the checks' ms alone and their share of the load. The meshes: ``--mesh``'s, else the shipped apartment
(../shared/scenes, if present), and procedural apartments written as PLY files; medians of ``--repeats`` loads,
after one to warm the caches.

    python benchmarks/scene_checks.py [--procedural 3] [--repeats 7] [--mesh PATH ...]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import timeit
from pathlib import Path

import numpy as np
import trimesh

from rvn_data.scenes import load_mesh_file
from rvn_data.scenes.plausibility import check_scene
from rvn_data.scenes.procedural import make_apartment

SHIPPED = Path(__file__).resolve().parents[2] / "shared" / "scenes" / "dream_apartment.glb"


def median_ms(fn, repeats: int) -> float:
    fn()  # warm: the file in the page cache, trimesh's and numpy's first calls
    return 1000 * statistics.median(timeit.repeat(fn, number=1, repeat=repeats))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--procedural", type=int, default=3, help="procedural apartments (train 0..N-1)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--mesh", nargs="*", default=[], help="more mesh files (metres, y-up)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        meshes = [Path(m) for m in args.mesh] + ([SHIPPED] if SHIPPED.is_file() and not args.mesh else [])
        for i in range(args.procedural):
            v, f = make_apartment("train", i).triangles()
            path = Path(tmp) / f"procedural_train_{i}.ply"
            trimesh.Trimesh(np.asarray(v, np.float64), f, process=False).export(path)
            meshes.append(path)
        print(f"{'mesh':<28} {'triangles':>10} {'load ms':>8} {'checks ms':>10} {'share':>6}")
        for path in meshes:
            scene = load_mesh_file(path)
            v, f = scene.triangles()
            load = median_ms(lambda: load_mesh_file(path), args.repeats)
            checks = median_ms(lambda: check_scene(v, f, path, "y", 1.0, False), args.repeats)
            print(f"{path.stem:<28} {len(f):>10,} {load:>8.1f} {checks:>10.1f} {checks / load:>6.0%}")


if __name__ == "__main__":
    main()
