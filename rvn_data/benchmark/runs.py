"""rvn-eval output directories as the report's rows: loading, identity, and merging shards.

A run's identity is what it recorded in ``run.json``: the policy config, the digest of its checkpoint
files, method, split, seed, episode, agent, camera, navmesh and env settings, and the commit of the
code (`rvn_data.provenance`). Runs of different identity are always different rows, whatever their
method label; runs whose identity differs only in which scenes they covered
(``episodes.first_scene`` / ``num_scenes``) are shards of one evaluation and are merged into one row,
their metrics recomputed from all records, and only when the episodes they share hold the same
record (else a ValueError names both folders). Rows that share a method label get the folder's name
beside it, so every row of a report has its own label.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from rvn_data.benchmark.metrics import compute_metrics, dumps_record, read_records
from rvn_data.benchmark.results import episode_set_digest
from rvn_data.benchmark.table import PAPER_RESULTS
from rvn_data.provenance import short

PAPER_BY_METHOD = {method: by_split for (_, method), by_split in PAPER_RESULTS.items()}
SHARD_KEYS = {"episodes": ("first_scene", "num_scenes"), "scenes": ("first_scene", "num_scenes")}


@dataclass
class Run:
    """One row: an rvn-eval out_dir (or several merged shards) with its metrics, records and run.json."""

    dir: Path
    metrics: dict
    records: list[dict]
    shards: list[Path] | None = None  # the out_dirs merged into this run (`merge_shards`)
    settings: dict | None = None  # run.json (None: written before rvn-eval recorded it, or copied without it)
    name: str | None = field(default=None)  # the row's label when the method is shared with another row

    @property
    def method(self) -> str:
        return self.name or str(self.metrics.get("method") or self.metrics.get("policy") or self.dir.name)

    @property
    def split(self) -> str:
        return str(self.metrics.get("split", "?"))

    @property
    def label(self) -> str:
        return f"{self.method} ({self.split})"

    @property
    def provenance(self) -> dict | None:
        return self.metrics.get("provenance") or (self.settings or {}).get("provenance")

    @property
    def commits(self) -> list[str]:
        """Every commit whose code wrote episodes of this row (several: resumed or merged across commits)."""
        provs = [self.provenance, *(self.metrics.get("resumed_by") or [])]
        return sorted({short(p) for p in provs})

    @property
    def episode_set(self) -> str:
        return episode_set_digest(self.records)

    def identity(self) -> str:
        """What must agree for two out_dirs to be shards of one evaluation (JSON text)."""
        if self.settings is None:
            ident = {k: self.metrics.get(k) for k in ("method", "policy", "split", "n_goals", "per_scene")}
        else:
            ident = {k: v for k, v in self.settings.items() if k not in ("provenance", "resumed_by")}
            for group, keys in SHARD_KEYS.items():
                ident[group] = {k: v for k, v in dict(ident.get(group) or {}).items() if k not in keys}
        ident["commits"] = self.commits
        return json.dumps(ident, sort_keys=True)

    def paper(self) -> tuple | None:
        """The paper's (SR_1, E(G), CPK) for this method and split, if the paper has them."""
        return PAPER_BY_METHOD.get(self.method, {}).get(self.split)


def load_run(path: str | Path) -> Run:
    """Read ``metrics.json``, ``episodes.jsonl`` (and ``run.json`` when present) of one rvn-eval out_dir."""
    d = Path(path)
    mpath, epath = d / "metrics.json", d / "episodes.jsonl"
    if not mpath.is_file():
        hint = ("the run is unfinished: rerun the same rvn-eval command to complete it" if epath.is_file()
                else "is it an rvn-eval out_dir?")
        raise ValueError(f"{d} has no metrics.json ({hint})")
    try:
        metrics = json.loads(mpath.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"{mpath} is not JSON ({err.msg}); rerun rvn-eval into {d}") from None
    missing = [k for k in ("SR_1", "E_G", "CPK", "episodes", "split") if k not in metrics]
    if missing:
        raise ValueError(f"{mpath} lacks {missing}; is it an rvn-eval metrics.json?")
    if not epath.is_file():
        raise ValueError(f"{d} has metrics.json but no episodes.jsonl; rerun rvn-eval into {d}")
    records = read_records(epath)
    if len(records) != metrics.get("episodes"):
        raise ValueError(f"{epath} holds {len(records)} episodes but {mpath} counts {metrics.get('episodes')}; "
                         f"rerun rvn-eval into {d} to rewrite both")
    settings = None
    if (d / "run.json").is_file():
        try:
            settings = json.loads((d / "run.json").read_text())
        except json.JSONDecodeError as err:
            raise ValueError(f"{d / 'run.json'} is not JSON ({err.msg}); rerun rvn-eval into {d}") from None
    # metrics recomputed from the records: a metrics.json written before a metric existed still reports it
    return Run(d, {**metrics, **compute_metrics(records)}, records, settings=settings)


def find_runs(paths: list[str | Path]) -> list[Run]:
    """Runs for each path: the path itself when it is an out_dir, else every out_dir below it. A folder below with
    episodes.jsonl but no metrics.json (a shard still running, or stopped, e.g. at its time limit) is refused by
    `load_run`, naming it: left out, its row would silently cover fewer episodes."""
    runs = []
    for p in paths:
        p = Path(p)
        if not p.is_dir():
            raise ValueError(f"{p} is not a directory (give rvn-eval out_dirs)")
        if (p / "metrics.json").is_file() or (p / "episodes.jsonl").is_file():
            runs.append(load_run(p))
            continue
        found = sorted({m.parent for name in ("metrics.json", "episodes.jsonl") for m in p.rglob(name)})
        if not found:
            raise ValueError(f"{p} holds no rvn-eval output (no metrics.json in it or below it)")
        runs += [load_run(f) for f in found]
    return runs


def _merge(group: list[Run]) -> Run:
    records: dict[tuple, dict] = {}
    source: dict[tuple, Path] = {}
    for g in group:
        for e in g.records:
            key = (e["scene_id"], e["episode_index"])
            if key in records and dumps_record(records[key]) != dumps_record(e):
                raise ValueError(f"{source[key]} and {g.dir} both hold episode {e['episode_id']} of {g.label} with other "
                                 "results: they are not shards of one evaluation; give one of them another method=")
            records[key], source[key] = e, g.dir
    merged = sorted(records.values(), key=lambda e: (e["scene_index"], e["scene_id"], e["episode_index"]))
    metrics = {**group[0].metrics, **compute_metrics(merged),
               "scenes": len({e["scene_id"] for e in merged}), "shards": [str(g.dir) for g in group]}
    return Run(group[0].dir, metrics, merged, [g.dir for g in group], group[0].settings)


def merge_shards(runs: list[Run]) -> list[Run]:
    """One row per identity (see the module's docstring), in order of first appearance; rows that
    share a method label and split are told apart by their folder's name."""
    groups: dict[str, list[Run]] = {}
    for r in runs:
        groups.setdefault(r.identity(), []).append(r)
    out = [group[0] if len(group) == 1 else _merge(group) for group in groups.values()]
    labels: dict[tuple[str, str], int] = {}
    for r in out:
        labels[(r.method, r.split)] = labels.get((r.method, r.split), 0) + 1
    for r in out:
        if labels[(r.method, r.split)] > 1:
            r.name = f"{r.method} [{r.dir.name}]"
    return out


def provenance_note(runs: list[Run]) -> str:
    """Lines above the table when rows come from different code or episode sets, ran on scenes that other splits
    share or that the model trained on, or on another robot or camera than their training data; else ''."""
    notes = []
    commits = sorted({c for r in runs for c in r.commits})
    if len(commits) > 1:
        notes.append(f"rows from different commits ({', '.join(commits)})")
    for split in dict.fromkeys(r.split for r in runs):
        sets = {r.episode_set for r in runs if r.split == split}
        if len(sets) > 1:
            notes.append(f"{split} rows on different episode sets ({len(sets)} sets: compare rows only within one)")
    text = f"**Warning: {'; '.join(notes)}; see the Runs table.**\n" if notes else ""
    shared = [(r.method, r.metrics["shared_scenes"]) for r in runs if r.metrics.get("shared_scenes")]
    if shared:  # rvn-eval on a mesh folder without split folders (rvn_data.scenes.sets.shared_splits)
        rows = "; ".join(f"{method} ({s['folder']}, also {' and '.join(s['splits'])})" for method, s in shared)
        text += ("**Warning: evaluated on scenes that other splits share (a mesh folder without a folder per split, "
                 f"so a model may have trained on them): {rows}.**\n")
    trained = [(r.method, r.metrics["trained_scenes"]) for r in runs if r.metrics.get("trained_scenes")]
    if trained:  # rvn-eval on scenes in the checkpoint's training data (rvn_data.benchmark.trained_scenes)
        rows = "; ".join(f"{method} ({len(t['scenes'])} of {t['evaluated']} scenes)" for method, t in trained)
        text += f"**Warning: evaluated on scenes the model trained on (not held-out figures): {rows}.**\n"
    return text + embodiment_note(runs)


def embodiment_note(runs: list[Run]) -> str:
    """One line naming the rows evaluated on another robot or camera than their training data
    (rvn-eval ``embodiment_mismatch=allow``), else ''."""
    from rvn_data.embodiment import describe

    other = [f"{r.method} ({describe(r.metrics['embodiment_mismatch'])})" for r in runs if r.metrics.get("embodiment_mismatch")]
    return f"Evaluated on another robot or camera than they were trained for: {'; '.join(other)}.\n" if other else ""
