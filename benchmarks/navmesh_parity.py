"""Navmesh parity with Habitat (issue 17): RVN's navmesh, both build profiles, against navmeshes
baked by real Recast/Detour with habitat-sim's settings, on dream_apartment and procedural val
scenes.

    python benchmarks/navmesh_parity.py                       # the committed Recast fixtures
    python benchmarks/navmesh_parity.py --bake --recast-dir R # re-bake them first (node + npm packages,
                                                              # see benchmarks/recast_bake.mjs)

Per scene and profile: the main island's area, RVN ÷ Recast; the relative difference of the
geodesic distance (RVN − Recast) / Recast over pairs of points navigable in both (both
distances are RVN's geodesic solver, on RVN's layers and on the Recast polygons, so Detour's own
sub-optimal paths do not count; each point at each mesh's own floor height, as Recast's
surface sits up to 0.2 m above the floor), median and 95th percentile of its magnitude; the share of pairs
reachable in one and not the other; the share of 5 cm grid points over the scene's x/z bounds
where one says navigable and the other not (a point counts as navigable when it is on any floor
of that mesh, each mesh queried at its own floor heights). Goals for the habitat profile: area
ratio 0.98–1.02, geodesic median ≤ 1 %, p95 ≤ 3 %, no reachability mismatch on any scene; each
goal prints PASS or FAIL, and a FAIL makes the exit status 1. The rvn profile has no goals against
Recast: it erodes by the exact agent radius where Recast rounds the radius up to whole cells, so
its larger islands are by design; its summary line is information.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "benchmarks" / "data" / "recast"
BAKE_SCRIPT = ROOT / "benchmarks" / "recast_bake.mjs"
DEFAULT_SCENES = ["dream_apartment"] + [f"procedural:val/{i}" for i in range(5)]
GOALS = {"area ratio": (0.98, 1.02), "geodesic median": 1.0, "geodesic p95": 3.0, "mismatch": 0.0}
JUDGED = {"habitat": GOALS}  # profile -> its goals against Recast; the others are shown as information
NO_GOALS = {"rvn": "no goals against Recast: exact-radius erosion, larger than Recast's whole cells by design"}


def fixture_name(spec: str) -> str:
    return "dream_apartment" if spec == "dream_apartment" else spec.split(":", 1)[1].replace("/", "_")


def load(spec: str, dream: Path):
    from rvn_data.scenes import load_scene
    return load_scene(dream if spec == "dream_apartment" else spec)


def bake(scene, out: Path, recast_dir: Path, radius: float, height: float) -> None:
    """Write the scene's triangles and bake `out` with real Recast (benchmarks/recast_bake.mjs)."""
    if shutil.which("node") is None:
        raise SystemExit("navmesh_parity: --bake needs node (Node.js 18+) on PATH")
    if not (recast_dir / "node_modules" / "@recast-navigation" / "generators").is_dir():
        raise SystemExit(f"navmesh_parity: {recast_dir}/node_modules has no @recast-navigation packages; run "
                         "npm install @recast-navigation/core@0.43.1 @recast-navigation/generators@0.43.1 there")
    v, f = scene.triangles()
    tris = recast_dir / f"{out.stem}.tris.bin"
    with open(tris, "wb") as fh:
        fh.write(np.array([len(v), len(f)], "<i4").tobytes())
        fh.write(np.ascontiguousarray(v, "<f4").tobytes())
        fh.write(np.ascontiguousarray(f, "<u4").tobytes())
    shutil.copy(BAKE_SCRIPT, recast_dir / BAKE_SCRIPT.name)
    out.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(["node", str(recast_dir / BAKE_SCRIPT.name), str(tris), str(out.resolve()), "--radius",
                    str(radius), "--height", str(height)], check=True, cwd=recast_dir)
    tris.unlink()


def navigable_on_grid(nm, xs: np.ndarray, zs: np.ndarray) -> np.ndarray:
    """bool [len(zs), len(xs)]: the point is navigable on some floor of `nm` (each layer's
    floor height where that layer has one)."""
    X, Z = np.meshgrid(xs, zs)
    out = np.zeros(X.shape, bool)
    for g in nm.layers:
        c = np.floor((X - g.x0) / g.cs).astype(np.int64)
        r = np.floor((Z - g.z0) / g.cs).astype(np.int64)
        inside = (r >= 0) & (c >= 0) & (r < g.shape[0]) & (c < g.shape[1])
        h = np.full(X.shape, np.nan)
        h[inside] = g.height[r[inside], c[inside]]
        m = np.isfinite(h) & ~out
        if m.any():
            pts = np.stack([X[m], h[m], Z[m]], 1)
            out[m] = np.asarray(nm.is_navigable(pts), bool)
    return out


def compare(nm, ref, scene, rng: np.random.Generator, n_pairs: int = 300, per_source: int = 10) -> dict:
    """The parity figures of navmesh `nm` against the reference `ref` (both RVN NavMesh) on
    `n_pairs` point pairs at least 1 m apart, `per_source` targets per source point."""
    def draw(k: int) -> np.ndarray:  # a point navigable in both, proposed by each mesh in turn
        for i in range(1000):
            p = (nm if (k + i) % 2 else ref).sample(rng, island=0)
            if nm.island_of(p) >= 0 and ref.island_of(p) >= 0:
                return np.asarray(p, np.float64)
        raise RuntimeError(f"{scene.scene_id}: no point navigable in both navmeshes")

    rel, mismatch, pairs, draws = [], 0, 0, 0
    on = lambda m, p: np.array([p[0], m.floor_height(p), p[2]])  # noqa: E731  each mesh's own floor
    while pairs < n_pairs and draws < 50 * n_pairs:
        a = draw(draws)
        for _ in range(min(per_source, n_pairs - pairs)):
            t, draws = draw(draws + 1), draws + 2
            if np.linalg.norm((t - a)[[0, 2]]) < 1.0:
                continue
            # string-pulled shortest paths (one Dijkstra per source, cached): exact lengths, where a
            # distance field's bilinear lookup beside a wall corner can be off by a cell or more
            x = nm.geodesic_distance(on(nm, t), on(nm, a))
            y = ref.geodesic_distance(on(ref, t), on(ref, a))
            pairs += 1
            if math.isfinite(x) != math.isfinite(y):
                mismatch += 1
            elif math.isfinite(x):
                rel.append(100.0 * (x - y) / y)
    lo, hi = np.asarray(scene.bounds)
    xs = np.arange(lo[0] + 0.025, hi[0], 0.05)
    zs = np.arange(lo[2] + 0.025, hi[2], 0.05)
    grid = navigable_on_grid(nm, xs, zs) != navigable_on_grid(ref, xs, zs)
    rel = np.abs(np.array(rel)) if rel else np.array([np.nan])
    return {"area": nm.island_areas[0], "area_recast": ref.island_areas[0],
            "area_ratio": nm.island_areas[0] / ref.island_areas[0],
            "geo_median_pct": float(np.median(rel)), "geo_p95_pct": float(np.percentile(rel, 95)),
            "pairs": pairs, "mismatch": mismatch / max(pairs, 1), "grid_disagree": float(grid.mean())}


def passes(f: dict, goals: dict = GOALS) -> dict:
    lo, hi = goals["area ratio"]
    return {"area ratio": lo <= f["area_ratio"] <= hi, "geodesic median": f["geo_median_pct"] <= goals["geodesic median"],
            "geodesic p95": f["geo_p95_pct"] <= goals["geodesic p95"], "mismatch": f["mismatch"] <= goals["mismatch"]}


def verdict(profile: str, rows: list[dict]) -> tuple[str, bool]:
    """The line judging ``profile``'s rows against its own goals, and whether all passed; a
    profile without goals gets an information line (and passes)."""
    goals = JUDGED.get(profile)
    if goals is None:
        return f"         information only ({NO_GOALS.get(profile, 'no goals for this profile')})", True
    ok = {goal: all(passes(r, goals)[goal] for r in rows) for goal in goals}
    return (f"         goals of the {profile} profile: " + ", ".join(f"{g} {'PASS' if v else 'FAIL'}" for g, v in ok.items()),
            all(ok.values()))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=DEFAULT_SCENES, help="dream_apartment and/or procedural:<split>/<i>")
    ap.add_argument("--dream", type=Path, default=ROOT.parent / "shared" / "scenes" / "dream_apartment.glb")
    ap.add_argument("--profiles", default="rvn,habitat")
    ap.add_argument("--pairs", type=int, default=300, help="point pairs per scene (10 per source point)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--bake", action="store_true", help="re-bake the Recast fixtures with node (--recast-dir)")
    ap.add_argument("--recast-dir", type=Path, default=None, help="folder whose node_modules has the packages")
    ap.add_argument("--json", type=Path, default=None, help="write the figures here")
    args = ap.parse_args(argv)
    from rvn_data.navmesh import NavMesh, NavMeshSettings
    from rvn_data.navmesh.source import load_navmesh_file

    profiles = args.profiles.split(",")
    if args.bake and args.recast_dir is None:
        ap.error("--bake needs --recast-dir")
    t0 = time.perf_counter()
    rows = []
    print(f"{'scene':<18} {'profile':<8} {'RVN m²':>8} {'Recast m²':>9} {'ratio':>6} {'geo med %':>9} "
          f"{'geo p95 %':>9} {'pairs':>5} {'unreach %':>9} {'grid %':>7}")
    for spec in args.scenes:
        if spec == "dream_apartment" and not args.dream.is_file():
            print(f"{spec:<18} skipped: {args.dream} not found (--dream PATH)")
            continue
        scene = load(spec, args.dream)
        fixture = FIXTURES / f"{fixture_name(spec)}.navmesh"
        if args.bake:
            bake(scene, fixture, args.recast_dir.resolve(), 0.18, 1.0)
        if not fixture.is_file():
            raise SystemExit(f"navmesh_parity: no Recast fixture {fixture}; bake it with --bake --recast-dir R")
        ref = load_navmesh_file(fixture, NavMeshSettings(agent_radius=0.18, agent_height=1.0), scene)
        for prof in profiles:
            nm = NavMesh.build(scene, NavMeshSettings(agent_radius=0.18, agent_height=1.0, profile=prof))
            f = compare(nm, ref, scene, np.random.default_rng(args.seed), args.pairs)
            rows.append({"scene": spec, "profile": prof, **f})
            print(f"{spec:<18} {prof:<8} {f['area']:8.2f} {f['area_recast']:9.2f} {f['area_ratio']:6.3f} "
                  f"{f['geo_median_pct']:9.2f} {f['geo_p95_pct']:9.2f} {f['pairs']:5d} {100 * f['mismatch']:9.1f} "
                  f"{100 * f['grid_disagree']:7.2f}", flush=True)
    print()
    failed = False
    for prof in profiles:
        mine = [r for r in rows if r["profile"] == prof]
        if not mine:
            continue
        ratios = [r["area_ratio"] for r in mine]
        print(f"{prof:<8} area ratio {min(ratios):.3f}–{max(ratios):.3f}, geodesic median ≤ "
              f"{max(r['geo_median_pct'] for r in mine):.2f} %, p95 ≤ {max(r['geo_p95_pct'] for r in mine):.2f} %, "
              f"unreachable in one only ≤ {100 * max(r['mismatch'] for r in mine):.1f} %, "
              f"grid disagreement {100 * min(r['grid_disagree'] for r in mine):.1f}–"
              f"{100 * max(r['grid_disagree'] for r in mine):.1f} %")
        line, ok = verdict(prof, mine)
        print(line)
        failed |= not ok
    print(f"wall time {time.perf_counter() - t0:.1f} s")
    if args.json:
        tmp = args.json.with_suffix(args.json.suffix + ".tmp")
        tmp.write_text(json.dumps(rows, indent=1) + "\n")
        os.replace(tmp, args.json)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
