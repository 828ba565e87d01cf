"""Procedural apartment figures (issue 2): generation time per scene (preferred < 0.3 s) and
triangle counts (budget <= 60k, target 5-20k), with the layout statistics behind them.

Run: python benchmarks/procedural.py [NUM_SCENES]   (default 20 train scenes spread over the split)
"""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from rvn_data.scenes.procedural import SPLITS, describe_apartment, make_apartment


def main(num: int = 20) -> None:
    count = SPLITS["train"][1]
    indices = np.linspace(0, count - 1, num).round().astype(int).tolist()
    make_apartment("train", 0)  # warm-up (imports, allocator)
    gen, tris, parts, rooms, furn, area = [], [], [], [], [], []
    for i in indices:
        t = time.perf_counter()
        scene = make_apartment("train", i)
        gen.append(time.perf_counter() - t)
        info = describe_apartment("train", i)
        tris.append(scene.num_triangles)
        parts.append(len(scene.parts))
        rooms.append(info.num_rooms)
        furn.append(info.num_furniture)
        area.append(info.area_m2)
    print(f"procedural apartments: {num} train scenes (indices {indices[0]}..{indices[-1]})")
    print(f"generation time per scene: mean {1e3 * statistics.mean(gen):.1f} ms, "
          f"median {1e3 * statistics.median(gen):.1f} ms, max {1e3 * max(gen):.1f} ms (goal < 300 ms)")
    print(f"triangles: mean {statistics.mean(tris):.0f}, max {max(tris)} (budget 60000)")
    print(f"parts (draw calls): mean {statistics.mean(parts):.1f}, max {max(parts)}")
    print(f"rooms: {min(rooms)}-{max(rooms)} (mean {statistics.mean(rooms):.1f}); furniture: "
          f"{min(furn)}-{max(furn)} (mean {statistics.mean(furn):.1f}); area m2: {min(area):.0f}-{max(area):.0f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
