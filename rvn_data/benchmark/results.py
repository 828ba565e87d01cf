"""An rvn-eval output directory: run identity, resumable per-episode records, final files.

``run.json`` holds what defines the run (policy, split, episode set, agent, camera, env
settings); resuming into a directory made by another run is an error naming the
setting. Records are appended to ``episodes.jsonl`` one line per ``write`` with fsync
as episodes finish; a torn last line from an interrupted run is dropped on resume. At
the end the file is rewritten in episode order, so it does not depend on the number
of workers.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from rvn_data.benchmark.episodes_store import check_settings
from rvn_data.navmesh.settings import recorded
from rvn_data.benchmark.metrics import dumps_record, read_records, write_records, write_text_atomic

IDENTITY_KEYS = ("policy", "method", "split", "seed", "scenes", "episodes", "agent", "navmesh", "camera", "env")


def run_identity(cfg: dict) -> dict:
    """The parts of an rvn-eval config that change its results (not workers/out_dir/backend)."""
    ident = {k: cfg.get(k) for k in IDENTITY_KEYS}
    ident["episodes"] = {k: v for k, v in dict(cfg.get("episodes") or {}).items() if k != "dir"}
    ident["scenes"] = {k: v for k, v in dict(cfg.get("scenes") or {}).items() if k != "root"}
    if ident["navmesh"] is not None:  # navmesh.source/file only when not the defaults
        ident["navmesh"] = recorded(dict(ident["navmesh"]))
    return json.loads(json.dumps(ident, sort_keys=True))


MOVED = {"rvn_data.policies.": "rvn_data.benchmark.policies."}  # reference policies' old module


def moved_targets(identity: dict) -> dict:
    """A stored run identity with the reference policies' ``_target_`` under today's module, so an
    out_dir written before the benchmark became a package resumes."""
    target = (identity.get("policy") or {}).get("_target_")
    for old, new in MOVED.items():
        if isinstance(target, str) and target.startswith(old):
            identity["policy"]["_target_"] = new + target[len(old):]
    return identity


def record_key(rec: dict) -> tuple[int, int]:
    return int(rec["scene_index"]), int(rec["episode_index"])


class RunDir:
    """Files of one rvn-eval run under ``out_dir``."""

    def __init__(self, out_dir: str | Path, identity: dict):
        self.dir = Path(out_dir)
        self.identity = identity
        self.run_path = self.dir / "run.json"
        self.records_path = self.dir / "episodes.jsonl"
        self.metrics_path = self.dir / "metrics.json"
        self.table_path = self.dir / "table.md"

    def open(self, resume: bool = True) -> dict[tuple[int, int], dict]:
        """Prepare the directory; returns the records already done (when resuming)."""
        self.dir.mkdir(parents=True, exist_ok=True)
        done: dict[tuple[int, int], dict] = {}
        if resume and self.run_path.exists():
            check_settings(self.run_path, moved_targets(json.loads(self.run_path.read_text())), self.identity, what="rvn-eval run",
                           hint="use another out_dir, or resume=false to start it over")
            if self.records_path.exists():
                for rec in read_records(self.records_path, drop_partial_tail=True):
                    done[record_key(rec)] = rec
        write_text_atomic(self.run_path, json.dumps(self.identity, sort_keys=True, indent=1) + "\n")
        write_records(self.records_path, done.values())  # clean file: no torn tail to append after
        for stale in (self.metrics_path, self.table_path):
            if stale.exists() and not done:
                stale.unlink()
        return done

    def append(self, rec: dict) -> None:
        """Append one record as a single write, flushed to disk."""
        data = (dumps_record(rec) + "\n").encode()
        fd = os.open(self.records_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)

    def finish(self, records: list[dict], metrics: dict, table: str) -> None:
        """Write episodes.jsonl (episode order), metrics.json and table.md atomically."""
        write_records(self.records_path, records)
        write_text_atomic(self.metrics_path, json.dumps(metrics, sort_keys=True, indent=1, allow_nan=False) + "\n")
        write_text_atomic(self.table_path, table)
