"""Issue 31 item 6: NoMaD-PointGoal (seed 0, one sample) against the number of training trajectories, from the
rows' per-episode logs: SR_1 with its 95 % Wilson interval, CPK with a 95 % bootstrap interval over episodes, and
a straight-line fit of SR_1 against log2(trajectories) extrapolated to the paper's 320k (a trend, not a claim).
    python docs/results/2026-11-26_main_levers/scale.py ROW_DIR:TRAJECTORIES ... -o scale.png
prints a table (markdown) and writes the plot."""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    p, d = k / n, 1 + z * z / n
    c, h = (p + z * z / (2 * n)) / d, z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


def row(path: Path) -> dict:
    eps = [json.loads(line) for line in (path / "episodes.jsonl").read_text().splitlines() if line.strip()]
    sr = np.array([bool(e["first_goal_success"]) for e in eps])
    col = np.array([e["collisions"] for e in eps], float)
    km = np.array([e["path_length"] for e in eps], float) / 1000.0
    rng = np.random.default_rng(0)
    boot = [col[i].sum() / km[i].sum() for i in (rng.integers(0, len(eps), len(eps)) for _ in range(2000))]
    ends = [e["termination"] for e in eps]
    return {"episodes": len(eps), "sr1": sr.mean(), "sr1_ci": wilson(int(sr.sum()), len(eps)),
            "cpk": col.sum() / km.sum(), "cpk_ci": tuple(np.percentile(boot, [2.5, 97.5])),
            "timeouts": ends.count("timeout")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", nargs="+", help="ROW_DIR:TRAJECTORIES")
    ap.add_argument("-o", "--out", default="scale.png")
    args = ap.parse_args()
    pts = sorted((int(n), Path(d)) for d, n in (r.rsplit(":", 1) for r in args.rows))
    rows = [(n, row(d)) for n, d in pts]
    print("| training trajectories | episodes | SR_1 [95 % CI] | CPK [95 % CI] | timeouts |")
    print("|---:|---:|---|---|---:|")
    for n, r in rows:
        print(f"| {n:,} | {r['episodes']} | {r['sr1']:.3f} [{r['sr1_ci'][0]:.3f}, {r['sr1_ci'][1]:.3f}] | "
              f"{r['cpk']:.1f} [{r['cpk_ci'][0]:.1f}, {r['cpk_ci'][1]:.1f}] | {r['timeouts']} |")
    x = np.log2([n for n, _ in rows])
    slope, icept = np.polyfit(x, [r["sr1"] for _, r in rows], 1)
    cslope, cicept = np.polyfit(x, np.log([r["cpk"] for _, r in rows]), 1)
    paper = math.log2(320_000)
    print(f"\nSR_1 = {icept:.3f} + {slope:.3f} log2(trajectories): +{slope:.3f} per doubling; at the paper's 320k "
          f"the line gives {icept + slope * paper:.2f} (paper 0.752; the line cannot pass the trajectory oracle's ceiling)")
    print(f"CPK x {math.exp(cslope):.2f} per doubling; at 320k the trend gives {math.exp(cicept + cslope * paper):.0f} "
          "(paper 35.7)")
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    ns = [n for n, _ in rows]
    for ax, key, label in ((axes[0], "sr1", "SR_1"), (axes[1], "cpk", "CPK (collisions per km)")):
        vals = [r[key] for _, r in rows]
        lo = [v - r[key + "_ci"][0] for v, (_, r) in zip(vals, rows)]
        hi = [r[key + "_ci"][1] - v for v, (_, r) in zip(vals, rows)]
        ax.errorbar(ns, vals, yerr=[lo, hi], marker="o", capsize=3)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("training trajectories (128 scenes)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_title("NoMaD-PointGoal, 200 val episodes")
    axes[1].set_title("95 % intervals: Wilson / bootstrap")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
