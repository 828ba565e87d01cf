"""Dataset-level files, written once every scene of the run's scene list has a record.

Each shard writes only its scenes' trajectory folders, maps and records
(``.rvn/scenes/<slug>.json``). `finalise` reads the records of the *full* scene list
(all shards) and writes, atomically and deterministically:

- ``data_splits/<name>/{train,test}/traj_names.txt``: split by scene, seeded (a seeded
  permutation of the sorted scene names; round((1 − train_fraction)·N) scenes, at least
  one when N ≥ 2 and train_fraction < 1, go to test);
- ``data_config.yaml``: ``<name>: {metric_waypoint_spacing: d_step}``, with comments for users of
  visualnav-transformer (spacing vs turns in place; negative clips are for NoMaD-Neg only);
- ``manifest.json``: counts and statistics per scene and in total.

The splits never shrink silently: they hold the union of every complete trajectory folder of
this dataset on disk, i.e. the scenes of the run's list plus the scenes done (or begun) by
earlier runs into the same out_dir with other lists, and folders beyond a scene's record (an
earlier run with more ``trajectories_per_scene``); the manifest names what came from earlier
runs (``kept_from_earlier_runs``) and rvn-gen's summary says so. They hold only whole folders: the
scene jobs check their scenes' folders in full and redo what is damaged; here the folders of
earlier runs are checked in full and those of the run's scene list for being there (another
shard's, or with ``mode=merge``); a trajectory that fails is left out, named in the manifest
(``left_out_of_splits``: name → what is wrong) and by rvn-gen's summary. When a ``traj_names.txt``
changes, the caches visualnav-transformer keeps beside it (``dataset_<name>.lmdb``,
``dataset_dist_*.pkl``; built once, never checked again) are removed.

The last shard to finish calls it and succeeds; earlier ones find scenes missing and
leave it to the others (or to ``rvn-gen mode=merge``). Running it twice writes the same bytes.
"""
from __future__ import annotations

import json
import os
import re
import shutil
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rvn_data.cache_root import build_lock
from rvn_data.dataset import naming, writer
from rvn_data.dataset.reader import is_complete, read_meta
from rvn_data.dataset.settings import GenSettings
from rvn_data.dataset.verify import Expect, not_whole


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


@dataclass
class Finalised:
    """What `finalise_dataset` did: ``missing`` specs (nothing written unless allowed),
    ``earlier`` slugs of scenes not in the run's list kept from earlier runs, ``extra``
    trajectory folders kept beyond their scene's record, ``left_out`` trajectories records list
    whose folder is gone or damaged (name → what is wrong), ``removed`` stale caches of the
    official GNM tooling (paths relative to out_dir), ``moved`` scenes whose split changed since
    the manifest before (slug → "test -> train" or "train -> test")."""

    missing: list[str]
    written: bool = False
    earlier: list[str] = field(default_factory=list)
    extra: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)
    left_out: dict[str, str] = field(default_factory=dict)
    moved: dict[str, str] = field(default_factory=dict)


def finalise(out_dir: Path, settings: GenSettings, specs: list[str], allow_missing: bool = False) -> list[str]:
    """Write splits, data_config and manifest over `specs` once every scene is done or has
    failed; returns the specs still missing (then nothing is written unless `allow_missing`).
    Failed scenes are listed in the manifest; their trajectories are simply absent.
    See `finalise_dataset` for the details."""
    return finalise_dataset(out_dir, settings, specs, allow_missing).missing


def finalise_dataset(out_dir: Path, settings: GenSettings, specs: list[str], allow_missing: bool = False) -> Finalised:
    """`finalise` with a report: the splits and manifest cover the union of the scenes of
    `specs` and every complete trajectory of this dataset already on disk (module docstring). Shards that finish at
    once take turns (a lock on ``.rvn/finalise.lock``, where the file system has ``flock``): each writes the train
    list, test list and manifest of what is on disk then, together (side by side, one's train list could stand
    beside another's test list, and their removals of the GNM caches collided)."""
    with build_lock(Path(out_dir) / ".rvn" / "finalise"):
        return _finalise_dataset(Path(out_dir), settings, specs, allow_missing)


def _finalise_dataset(out_dir: Path, settings: GenSettings, specs: list[str], allow_missing: bool) -> Finalised:
    missing = missing_scenes(out_dir, specs)
    if missing and not allow_missing:
        return Finalised(missing)
    failed = failed_scenes(out_dir, specs)
    listed = [naming.scene_slug(spec) for spec in specs]
    records = {}
    for slug in listed:
        record = writer.read_record(writer.record_path(out_dir, slug))
        if record is not None:
            records[slug] = record
    # the union with what is on disk: scenes done by earlier runs with other scene lists, folders
    # beyond a record (an earlier, larger trajectories_per_scene) and scenes begun but never finished
    earlier = _earlier_records(out_dir, set(listed))
    records.update(earlier)
    kept = [t["name"] for r in earlier.values() for t in r["trajectories"]]
    for slug, metas in _extra_trajectories(out_dir, settings.kind, records).items():
        if slug in records:
            records[slug]["trajectories"] = sorted(records[slug]["trajectories"] + [_entry(m) for m in metas],
                                                   key=_index)
        elif slug not in listed:  # a listed scene without a record has failed or is missing: reported as such
            records[slug] = earlier[slug] = _unfinished_record(metas)
        else:
            continue
        kept += [m["name"] for m in metas]
    left_out = not_whole(out_dir, sorted(t["name"] for r in records.values() for t in r["trajectories"]), set(kept),
                         Expect.of_settings(settings))
    for slug, r in records.items():
        if any(t["name"] in left_out for t in r["trajectories"]):
            records[slug] = {**r, "trajectories": [t for t in r["trajectories"] if t["name"] not in left_out]}
    train, test = split_scenes(sorted(set(listed) | set(records)), settings.seed, settings.train_fraction)
    base = out_dir / "data_splits" / settings.name
    moved = _moved(out_dir / "manifest.json", train, test)
    removed = []
    for part, slugs in (("train", train), ("test", test)):
        names = [t["name"] for slug in slugs if slug in records for t in records[slug]["trajectories"]]
        removed += _write_split(out_dir, base / part, "".join(f"{n}\n" for n in names))
    writer.write_text_atomic(out_dir / "data_config.yaml", data_config_text(settings))
    writer.write_text_atomic(out_dir / "manifest.json", writer.dumps_json(
        _manifest(settings, specs, records, train, test, missing, failed, sorted(earlier), sorted(kept), left_out)))
    return Finalised(missing, True, sorted(earlier), sorted(kept), removed, left_out, moved)


def _moved(manifest: Path, train: list[str], test: list[str]) -> dict[str, str]:
    """slug → "<old> -> <new>" for the scenes the manifest before put on the other side (none without one)."""
    try:
        before = {slug: e["gnm_split"] for slug, e in json.loads(manifest.read_text())["per_scene"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}
    now = {**{slug: "train" for slug in train}, **{slug: "test" for slug in test}}
    return {slug: f"{before[slug]} -> {side}" for slug, side in sorted(now.items())
            if before.get(slug) in ("train", "test") and before[slug] != side}


# visualnav-transformer's ViNT_Dataset builds these beside traj_names.txt once and never checks them again
GNM_CACHE_PATTERNS = ("dataset_*.lmdb", "dataset_*.lmdb-lock", "dataset_dist_*.pkl")


def _write_split(out_dir: Path, folder: Path, text: str) -> list[str]:
    """Write ``folder/traj_names.txt``; when its list changes, remove the official tooling's
    caches of the old list there. Returns the removed paths (relative to out_dir)."""
    path = folder / "traj_names.txt"
    old = path.read_text() if path.is_file() else None
    removed = []
    if old != text and folder.is_dir():
        for pattern in GNM_CACHE_PATTERNS:
            for cache in sorted(folder.glob(pattern)):
                if cache.is_dir() and not cache.is_symlink():
                    shutil.rmtree(cache)
                else:
                    cache.unlink()
                removed.append(cache.relative_to(out_dir).as_posix())
    if old != text:
        writer.write_text_atomic(path, text)
    return removed


def data_config_text(s: GenSettings) -> str:
    """``data_config.yaml``: the entry visualnav-transformer's data_config needs, with what a
    user of the official tooling must know about it."""
    head = ("# GNM data config (visualnav-transformer): metres between consecutive frames' "
            "positions of a MOVE_FORWARD\n"
            "# = agent.d_step, one forward step. About 45 % of the steps are turns in place (no motion),\n"
            "# so consecutive frames are on average only ~0.14 m apart (default agent); see docs/DATASET.md.\n")
    if s.kind == "negative":
        head += ("# NEGATIVE clips: every trajectory ends in a collision. Only RVN's NoMaD-Neg trainer uses them\n"
                 "# (rvn-train model=nomad_neg data.negative_root=<this folder>); do not add this dataset to\n"
                 "# visualnav-transformer's data_config: its trainer would learn the collisions as demonstrations.\n")
    else:
        head += "# To train with visualnav-transformer, copy the entry below into its data_config.yaml.\n"
    return head + f"{s.name}:\n  metric_waypoint_spacing: {s.agent.d_step}\n"


def _earlier_records(out_dir: Path, listed: set[str]) -> dict[str, dict]:
    """slug → record of the scenes done by earlier runs whose scene list did not hold them."""
    folder = out_dir / ".rvn" / "scenes"
    if not folder.is_dir():
        return {}
    out = {}
    for path in sorted(folder.glob("*.json")):
        if path.name.startswith(".") or path.stem in listed:
            continue
        record = writer.read_record(path)
        if record is not None:
            out[path.stem] = record
    return out


def _extra_trajectories(out_dir: Path, kind: str, records: dict[str, dict]) -> dict[str, list[dict]]:
    """slug → sidecars of the complete trajectory folders of this kind that no record lists."""
    known = {t["name"] for r in records.values() for t in r["trajectories"]}
    pattern = re.compile(rf".+_{re.escape(kind)}_\d+")
    out: dict[str, list[dict]] = {}
    with os.scandir(out_dir) as it:
        names = sorted(e.name for e in it if e.is_dir() and pattern.fullmatch(e.name) and e.name not in known)
    for name in names:
        if not is_complete(out_dir / name):
            continue
        try:
            meta = read_meta(out_dir / name)
        except ValueError:
            continue
        if meta.get("kind") != kind or not meta.get("spec") or meta.get("name") != name:
            continue
        out.setdefault(naming.scene_slug(meta["spec"]), []).append(meta)
    return out


def _index(t: dict) -> int:
    return int(t["index"]) if t.get("index") is not None else int(t["name"].rsplit("_", 1)[1])


def _entry(m: dict) -> dict:
    return {"name": m["name"], "index": m["index"], "frames": m["frames"], "t_c": m["t_c"],
            "path_length": m["path_length"], "attempt": m["attempt"]}


def _unfinished_record(metas: list[dict]) -> dict:
    """A scene record rebuilt from the sidecars of a scene begun but not finished."""
    rejected = Counter()
    for m in metas:
        rejected.update(m.get("rejected") or {})
    return {"scene": metas[0]["scene"], "spec": metas[0]["spec"], "unfinished": True,
            "trajectories": sorted((_entry(m) for m in metas), key=_index), "failed": [],
            "rejected": dict(sorted(rejected.items())), "attempts": int(sum(rejected.values()) + len(metas)),
            "renderers": sorted({m["renderer"] for m in metas if m.get("renderer")})}


def _manifest(s: GenSettings, specs, records, train, test, missing, failed, earlier=(), kept=(), left_out=None) -> dict:
    trajs = [t for r in records.values() for t in r["trajectories"]]
    rejected = Counter()
    for r in records.values():
        rejected.update(r["rejected"])
    test_set = set(test)
    out = {
        "dataset": s.name, "kind": s.kind, "seed": s.seed, "format": "GNM",
        "metric_waypoint_spacing": s.agent.d_step,
        "scenes": {"listed": len(specs), "done": sum(not r.get("unfinished") for r in records.values()), "train": len(train), "test": len(test),
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
    for slug, r in records.items():
        if r.get("unfinished"):
            out["per_scene"][slug]["unfinished"] = True
    if earlier or kept:  # on disk from earlier runs, not in this run's scene list or trajectories_per_scene
        out["kept_from_earlier_runs"] = {"scenes": list(earlier), "trajectories": list(kept)}
    if left_out:  # listed by a record, gone or damaged on disk: not in the splits
        out["left_out_of_splits"] = dict(left_out)
    if s.kind == "negative":
        out["t_c"] = _stats([t["t_c"] for t in trajs])
    return out
