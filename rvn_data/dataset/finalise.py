"""Dataset-level files, written once every scene of the run's scene list has a record.

Each shard writes only its scenes' trajectory folders, maps and records
(``.rvn/scenes/<slug>.json``). `finalise` reads the records of the *full* scene list
(all shards) and writes, atomically and deterministically:

- ``data_splits/<name>/{train,test}/traj_names.txt``: split by scene, seeded (a seeded
  permutation of the sorted scene names; round((1 − train_fraction)·N) scenes, at least
  one when N ≥ 2 and train_fraction < 1, go to test);
- ``data_config.yaml``: ``<name>: {metric_waypoint_spacing: d_step}``;
- ``manifest.json``: counts and statistics per scene and in total.

The last shard to finish calls it and succeeds; earlier ones find scenes missing and
leave it to the others (or to ``rvn-gen mode=merge``). Running it twice writes the same bytes.
"""
from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np

from rvn_data.dataset import naming, writer
from rvn_data.dataset.settings import GenSettings


def split_scenes(slugs: list[str], seed: int, train_fraction: float) -> tuple[list[str], list[str]]:
    """Seeded scene split → (train slugs, test slugs), both sorted."""
    ordered = sorted(slugs)
    n = len(ordered)
    n_test = int(round(n * (1.0 - train_fraction)))
    if n >= 2 and train_fraction < 1.0:
        n_test = max(n_test, 1)
    if train_fraction > 0.0 and n >= 1:
        n_test = min(n_test, n - 1)
    perm = np.random.default_rng([seed, 5117]).permutation(n)
    test = sorted(ordered[i] for i in perm[:n_test])
    return sorted(set(ordered) - set(test)), test


def failure_path(out_dir: Path, slug: str) -> Path:
    return Path(out_dir) / ".rvn" / "failed" / f"{slug}.txt"


def missing_scenes(out_dir: Path, specs: list[str]) -> list[str]:
    """Specs of the list with neither a record nor a failure note yet."""
    return [spec for spec in specs if not writer.record_path(out_dir, naming.scene_slug(spec)).is_file()
            and not failure_path(out_dir, naming.scene_slug(spec)).is_file()]


def failed_scenes(out_dir: Path, specs: list[str]) -> dict[str, str]:
    """spec → error message of the scenes whose last run failed."""
    out = {}
    for spec in specs:
        path = failure_path(out_dir, naming.scene_slug(spec))
        if path.is_file() and not writer.record_path(out_dir, naming.scene_slug(spec)).is_file():
            out[spec] = path.read_text().strip()
    return out


def _stats(values: list[float]) -> dict:
    if not values:
        return {"count": 0}
    v = np.asarray(values, np.float64)
    return {"count": int(v.size), "mean": round(float(v.mean()), 4), "min": round(float(v.min()), 4),
            "max": round(float(v.max()), 4)}


def finalise(out_dir: Path, settings: GenSettings, specs: list[str], allow_missing: bool = False) -> list[str]:
    """Write splits, data_config and manifest over `specs` once every scene is done or has
    failed; returns the specs still missing (then nothing is written unless `allow_missing`).
    Failed scenes are listed in the manifest; their trajectories are simply absent."""
    out_dir = Path(out_dir)
    missing = missing_scenes(out_dir, specs)
    if missing and not allow_missing:
        return missing
    failed = failed_scenes(out_dir, specs)
    records = {}
    for spec in specs:
        path = writer.record_path(out_dir, naming.scene_slug(spec))
        if path.is_file():
            records[naming.scene_slug(spec)] = json.loads(path.read_text())
    train, test = split_scenes([naming.scene_slug(s) for s in specs], settings.seed, settings.train_fraction)
    base = out_dir / "data_splits" / settings.name
    for part, slugs in (("train", train), ("test", test)):
        names = [t["name"] for slug in slugs if slug in records for t in records[slug]["trajectories"]]
        writer.write_text_atomic(base / part / "traj_names.txt", "".join(f"{n}\n" for n in names))
    writer.write_text_atomic(out_dir / "data_config.yaml",
                             f"# GNM data config (visualnav-transformer): metres between consecutive frames' "
                             f"positions of a MOVE_FORWARD\n{settings.name}:\n"
                             f"  metric_waypoint_spacing: {settings.agent.d_step}\n")
    writer.write_text_atomic(out_dir / "manifest.json", writer.dumps_json(
        _manifest(settings, specs, records, train, test, missing, failed)))
    return missing


def _manifest(s: GenSettings, specs, records, train, test, missing, failed) -> dict:
    trajs = [t for r in records.values() for t in r["trajectories"]]
    rejected = Counter()
    for r in records.values():
        rejected.update(r["rejected"])
    test_set = set(test)
    out = {
        "dataset": s.name, "kind": s.kind, "seed": s.seed, "format": "GNM",
        "metric_waypoint_spacing": s.agent.d_step,
        "scenes": {"listed": len(specs), "done": len(records), "train": len(train), "test": len(test),
                   "missing": [str(m) for m in missing], "failed": {str(k): v for k, v in sorted(failed.items())}},
        "trajectories": len(trajs),
        "trajectories_failed": sum(len(r["failed"]) for r in records.values()),
        "attempts": sum(r["attempts"] for r in records.values()),
        "rejected": dict(sorted(rejected.items())),
        "frames": sum(t["frames"] for t in trajs),
        "frames_per_trajectory": _stats([t["frames"] for t in trajs]),
        "path_length_m": _stats([t["path_length"] for t in trajs]),
        "renderers": sorted({b for r in records.values() for b in r["renderers"]}),
        "per_scene": {slug: {"scene": r["scene"], "gnm_split": "test" if slug in test_set else "train",
                             "trajectories": len(r["trajectories"]), "failed": len(r["failed"]),
                             "frames": sum(t["frames"] for t in r["trajectories"]), "attempts": r["attempts"]}
                      for slug, r in sorted(records.items())},
        "settings": s.identity(),
    }
    if s.kind == "negative":
        out["t_c"] = _stats([t["t_c"] for t in trajs])
    return out
