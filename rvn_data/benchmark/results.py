"""An rvn-eval output directory: run identity, resumable per-episode records, final files.

``run.json`` holds what defines the run (policy, split, episode set, agent, camera, env
settings, and for a checkpoint policy a digest of its files and of the other model folders the loaded
policy names as read, ``policy.loaded_files``); resuming into a directory made by another run is an error naming the setting. Beside it, ``provenance`` records the code that
started the run (`rvn_data.provenance`: commit, dirty tree, versions) and ``resumed_by`` any other
code that later added episodes to it; ``metrics.json`` carries both. Records are appended to ``episodes.jsonl`` one line per ``write`` with fsync
as episodes finish; a torn last line from an interrupted run is dropped on resume. At
the end the file is rewritten in episode order, so it does not depend on the number
of workers.
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from rvn_data.benchmark.episodes_store import check_settings
from rvn_data.identity import other_dir
from rvn_data.navmesh.settings import recorded
from rvn_data.benchmark.metrics import dumps_record, read_records, write_records, write_text_atomic
from rvn_data.provenance import provenance, short

IDENTITY_KEYS = ("policy", "method", "split", "seed", "scenes", "episodes", "agent", "navmesh", "camera", "env")


def run_identity(cfg: dict, loaded_files: dict[str, str] | None = None) -> dict:
    """The parts of an rvn-eval config that change its results (not workers/out_dir/backend); ``loaded_files``: the
    loaded policy's ``loaded_files`` (`policy_files_digest`)."""
    ident = {k: cfg.get(k) for k in IDENTITY_KEYS}
    ident["episodes"] = {k: v for k, v in dict(cfg.get("episodes") or {}).items() if k != "dir"}
    ident["scenes"] = {k: v for k, v in dict(cfg.get("scenes") or {}).items() if k != "root"}
    files = policy_files_digest(cfg.get("policy") or {}, loaded_files)
    if files:
        ident["policy_files"] = files
    if ident["navmesh"] is not None:  # navmesh.source/file only when not the defaults
        ident["navmesh"] = recorded(dict(ident["navmesh"]))
    return json.loads(json.dumps(ident, sort_keys=True))


WEIGHT_FILES = (".safetensors", ".pt", ".pth", ".yaml", ".json")
SKIP_FILES = ("state.pt",)  # optimizer state: not what the policy runs


def policy_files_digest(policy: dict, loaded_files: dict[str, str] | None = None) -> dict[str, str]:
    """``{setting: sha1}`` of the checkpoint folders a policy config names (``checkpoint_path``, ``ensemble``) and of
    ``loaded_files``, the other folders the loaded policy says it read (the policy contract's ``loaded_files``,
    ``{setting: folder}``: an RL policy's frozen depth model, under ``depth_model_path``): every weight and config file
    below each, by relative path and content, so an evaluation of retrained weights in the same folder is another
    run. Logs are left out."""
    paths: dict[str, str] = {}
    for key, value in policy.items():
        if key.endswith("checkpoint_path") and isinstance(value, str):
            paths[key] = value
        elif key == "ensemble" and value:
            for i, v in enumerate([value] if isinstance(value, str) else list(value)):
                paths[f"ensemble.{i}"] = str(v)
    paths.update({str(k): str(v) for k, v in (loaded_files or {}).items()})
    out = {}
    for key, value in paths.items():
        root = Path(value).expanduser()
        if not root.is_dir():
            continue  # the policy's own check names the missing folder
        h = hashlib.sha1()
        for f in sorted(p for p in root.rglob("*") if p.is_file()):
            rel = f.relative_to(root)
            if (f.suffix in WEIGHT_FILES or f.name == "latest") and f.name not in SKIP_FILES \
                    and not any(part.startswith((".", "tb")) for part in rel.parts):
                h.update(rel.as_posix().encode() + b"\0")
                with open(f, "rb") as fh:
                    for chunk in iter(lambda: fh.read(1 << 20), b""):
                        h.update(chunk)
        out[key] = h.hexdigest()[:16]
    return out


def episode_key(record: dict) -> tuple[str, int, float]:
    """What tells one episode from another across runs (scene, episode index, first-goal distance): runs of
    another episode seed name their episodes alike, their first goals differ."""
    return str(record["scene_id"]), int(record["episode_index"]), round(float(record["d0"] or 0.0), 4)


def episode_set_digest(records: list[dict]) -> str:
    """Digest of the episodes a run drove (`episode_key`): runs with the same digest drove the same start poses
    and first goals."""
    keys = sorted(episode_key(r) for r in records)
    return hashlib.sha1(json.dumps(keys).encode()).hexdigest()[:12]


MOVED = {"rvn_data.policies.": "rvn_data.benchmark.policies."}  # reference policies' old module


def moved_targets(identity: dict) -> dict:
    """A stored run identity with the reference policies' ``_target_`` under today's module, so an
    out_dir written before the benchmark became a package resumes."""
    target = (identity.get("policy") or {}).get("_target_")
    for old, new in MOVED.items():
        if isinstance(target, str) and target.startswith(old):
            identity["policy"]["_target_"] = new + target[len(old):]
    return identity


def moved_folders(stored: dict, identity: dict) -> None:
    """A checkpoint folder the stored run named by another path (a link to it, the runs folder moved or mounted
    elsewhere) whose files are the same (their digest, ``policy_files``) is the same policy: its path in ``stored`` is
    taken as this run's, so the run resumes (and run.json names the path it was last reached by)."""
    old, new = stored.get("policy") or {}, identity.get("policy") or {}
    for key, path in new.items():
        digest = (identity.get("policy_files") or {}).get(key)
        if key.endswith("checkpoint_path") and old.get(key) != path and digest is not None \
                and (stored.get("policy_files") or {}).get(key) == digest:
            old[key] = path


def record_key(rec: dict) -> tuple[int, int]:
    return int(rec["scene_index"]), int(rec["episode_index"])


class RunDir:
    """Files of one rvn-eval run under ``out_dir``."""

    NOTES = ("embodiment_mismatch",)  # recorded in run.json beside the identity, not part of it

    def __init__(self, out_dir: str | Path, identity: dict, notes: dict | None = None):
        self.dir = Path(out_dir)
        self.identity = identity
        self.notes = {k: v for k, v in (notes or {}).items() if k in self.NOTES and v}
        self.run_path = self.dir / "run.json"
        self.records_path = self.dir / "episodes.jsonl"
        self.metrics_path = self.dir / "metrics.json"
        self.table_path = self.dir / "table.md"
        self.provenance = provenance()
        self.resumed_by: list[dict] = []
        self._resumer: dict | None = None  # this code, resuming another's run: recorded with its first episode

    def open(self, resume: bool = True) -> dict[tuple[int, int], dict]:
        """Prepare the directory; returns the records already done (when resuming)."""
        self.dir.mkdir(parents=True, exist_ok=True)
        done: dict[tuple[int, int], dict] = {}
        started_by = self.provenance
        records = read_records(self.records_path, drop_partial_tail=True) \
            if resume and self.records_path.exists() else []
        # a run that recorded no episode (it failed before its first, e.g. on a scene's settings) starts over, whatever
        # its settings were: nothing of it would be mixed with this run's
        if records and self.run_path.exists():
            stored = moved_targets(json.loads(self.run_path.read_text()))
            earlier, resumed_by = stored.pop("provenance", None), stored.pop("resumed_by", [])
            for key in self.NOTES:
                stored.pop(key, None)
            if "policy_files" in self.identity and "policy_files" not in stored:
                stored["policy_files"] = self.identity["policy_files"]  # a run.json from before the digest
            files = self.identity.get("policy_files", {})
            if "depth_model_path" in files and "depth_model_path" not in stored["policy_files"]:
                stored["policy_files"]["depth_model_path"] = files["depth_model_path"]  # from before it was counted
            moved_folders(stored, self.identity)
            check_settings(self.run_path, stored, self.identity, what="rvn-eval run",
                           hint=f"use another out_dir (e.g. out_dir={other_dir(self.dir, stored, self.identity)}), "
                           "or resume=false to start it over")
            for rec in records:
                done[record_key(rec)] = rec
            if done:  # episodes of the earlier code stay: record both
                started_by = earlier or {"commit": None, "dirty": None, "version": "unknown", "generator_version": None}
                self.resumed_by = list(resumed_by)
                if short(self.provenance) not in {short(p) for p in [started_by, *self.resumed_by]}:
                    self._resumer = self.provenance  # other code: recorded once it adds an episode (`append`)
        self.provenance = started_by
        self._write_run()
        write_records(self.records_path, done.values())  # clean file: no torn tail to append after
        for stale in (self.metrics_path, self.table_path):
            if stale.exists() and not done:
                stale.unlink()
        return done

    def _write_run(self) -> None:
        record = {**self.identity, **self.notes, "provenance": self.provenance,
                  **({"resumed_by": self.resumed_by} if self.resumed_by else {})}
        write_text_atomic(self.run_path, json.dumps(record, sort_keys=True, indent=1) + "\n")

    def append(self, rec: dict) -> None:
        """Append one record, flushed to disk. A write that stores part of it (a full disk) is continued until the
        line is whole, or its OSError raised: a torn line followed by the next record could not be resumed. The first
        record other code adds to a run records that code in ``resumed_by`` (a resume that adds none changes nothing)."""
        if self._resumer is not None:
            self.resumed_by.append(self._resumer)
            self._resumer = None
            self._write_run()
        data = memoryview((dumps_record(rec) + "\n").encode())
        fd = os.open(self.records_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            while data:
                data = data[os.write(fd, data):]
            os.fsync(fd)
        finally:
            os.close(fd)

    def finish(self, records: list[dict], metrics: dict, table: str) -> None:
        """Write episodes.jsonl (episode order), metrics.json and table.md atomically."""
        write_records(self.records_path, records)
        metrics = {**metrics, "provenance": self.provenance, "episode_set": episode_set_digest(records)}
        if self.resumed_by:
            metrics["resumed_by"] = self.resumed_by
        write_text_atomic(self.metrics_path, json.dumps(metrics, sort_keys=True, indent=1, allow_nan=False) + "\n")
        write_text_atomic(self.table_path, table)
