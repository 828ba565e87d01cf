"""Results report (markdown + PNG plots) from rvn-eval output directories.

    python -m rvn_data.benchmark.report RUN_DIR [RUN_DIR ...] -o report.md [--title TEXT]

Each RUN_DIR is an rvn-eval ``out_dir`` (``metrics.json`` + ``episodes.jsonl``; one per
policy × split) or a folder searched for them. Runs with the same method and split are
shards of one evaluation (e.g. over ``episodes.first_scene``): they are merged and their
metrics recomputed from all records. The report holds the results table in the paper's
layout (`rvn_data.benchmark.table`, paper rows included), our numbers beside the paper's per
method and split, run details with links to the per-episode logs, plots written next to
the report (``<stem>_sr1.png``, ``<stem>_cpk.png``, ``<stem>_goals.png``) and every
episode's record. Runs appear in the order given.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from rvn_data.benchmark.metrics import TERMINATIONS, format_metric, read_records, write_text_atomic
from rvn_data.benchmark.plots import bar_plot, goals_plot
from rvn_data.benchmark.significance import Row, significance_table
from rvn_data.benchmark.table import PAPER_RESULTS, SPLIT_TITLES, render_table

PAPER_BY_METHOD = {method: by_split for (_, method), by_split in PAPER_RESULTS.items()}


@dataclass
class Run:
    """One rvn-eval output directory: its metrics and per-episode records."""

    dir: Path
    metrics: dict
    records: list[dict]
    shards: list[Path] | None = None  # the out_dirs merged into this run (`merge_shards`)

    @property
    def method(self) -> str:
        return str(self.metrics.get("method") or self.metrics.get("policy") or self.dir.name)

    @property
    def split(self) -> str:
        return str(self.metrics.get("split", "?"))

    @property
    def label(self) -> str:
        return f"{self.method} ({self.split})"

    def paper(self) -> tuple | None:
        """The paper's (SR_1, E(G), CPK) for this method and split, if the paper has them."""
        return PAPER_BY_METHOD.get(self.method, {}).get(self.split)


def load_run(path: str | Path) -> Run:
    """Read ``metrics.json`` and ``episodes.jsonl`` of one rvn-eval out_dir."""
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
    return Run(d, metrics, records)


def find_runs(paths: list[str | Path]) -> list[Run]:
    """Runs for each path: the path itself when it is an out_dir, else every out_dir below it."""
    runs = []
    for p in paths:
        p = Path(p)
        if not p.is_dir():
            raise ValueError(f"{p} is not a directory (give rvn-eval out_dirs)")
        if (p / "metrics.json").is_file() or (p / "episodes.jsonl").is_file():
            runs.append(load_run(p))
            continue
        found = sorted(m.parent for m in p.rglob("metrics.json"))
        if not found:
            raise ValueError(f"{p} holds no rvn-eval output (no metrics.json in it or below it)")
        runs += [load_run(f) for f in found]
    return runs


def merge_shards(runs: list[Run]) -> list[Run]:
    """Combine runs of the same method and split (shards of one evaluation, e.g. over
    ``episodes.first_scene``) into one: their records, metrics recomputed over all of them.
    Order: first appearance. Shards must agree on N_goal and episodes per scene."""
    from rvn_data.benchmark.metrics import compute_metrics

    groups: dict[tuple[str, str], list[Run]] = {}
    for r in runs:
        groups.setdefault((r.method, r.split), []).append(r)
    out = []
    for (method, split), group in groups.items():
        if len(group) == 1:
            out.append(group[0])
            continue
        for key in ("n_goals", "per_scene", "policy"):
            values = {json.dumps(g.metrics.get(key)) for g in group}
            if len(values) > 1:
                raise ValueError(f"runs of {method} ({split}) differ in {key} ({', '.join(sorted(values))}): "
                                 f"{', '.join(str(g.dir) for g in group)}; give them distinct method= names")
        records = {(e["scene_id"], e["episode_index"]): e for g in group for e in g.records}
        merged = sorted(records.values(), key=lambda e: (e["scene_index"], e["scene_id"], e["episode_index"]))
        metrics = {**group[0].metrics, **compute_metrics(merged),
                   "scenes": len({e["scene_id"] for e in merged}), "shards": [str(g.dir) for g in group]}
        out.append(Run(group[0].dir, metrics, merged, [g.dir for g in group]))
    return out


def _rel(path: Path, base: Path) -> str:
    return Path(os.path.relpath(Path(path).resolve(), Path(base).resolve())).as_posix()


def beside_paper(runs: list[Run]) -> str:
    """Markdown table: per run, SR_1 / E(G) / CPK ours next to the paper's (same method and split)."""
    lines = ["| Method | Split | SR_1 ours | SR_1 paper | E(G) ours | E(G) paper | CPK ours | CPK paper |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in runs:
        m, p = r.metrics, r.paper() or (None, None, None)
        cells = [r.method, SPLIT_TITLES.get(r.split, r.split)]
        for ours, paper, digits in ((m["SR_1"], p[0], 3), (m["E_G"], p[1], 2), (m["CPK"], p[2], 1)):
            cells += [format_metric(ours, digits), "" if paper is None else format_metric(paper, digits)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def run_details(runs: list[Run], base: Path) -> str:
    """Markdown table of each run's set-up, secondary metrics, terminations and log path."""
    lines = ["| Method | Policy | Split | Scenes × episodes | N_goal | Episodes | SPL_1 | Path/episode (m) | "
             "Collisions | Steps | " + " / ".join(TERMINATIONS) + " | Per-episode log |",
             "|---|---|---|---|---:|---:|---:|---:|---:|---:|---|---|"]
    for r in runs:
        m = r.metrics
        ends = Counter(rec["termination"] for rec in r.records)
        logs = ", ".join(f"[{x}]({x})" for x in (_rel(d / "episodes.jsonl", base) for d in (r.shards or [r.dir])))
        lines.append(f"| {r.method} | {m.get('policy', '')} | {r.split} | {m.get('scenes', '?')} × {m.get('per_scene', '?')} "
                     f"| {m.get('n_goals', '?')} | {m['episodes']} | {format_metric(m.get('SPL_1'), 3)} "
                     f"| {format_metric(m.get('path_length'), 2)} | {m.get('collisions', '')} | {m.get('steps', '')} "
                     f"| {' / '.join(str(ends.get(t, 0)) for t in TERMINATIONS)} | {logs} |")
    return "\n".join(lines) + "\n"


def tests(runs: list[Run], compare: list[tuple[str, str]] | None = None) -> str:
    """Significance of the differences between rows of the same split (rvn_data.benchmark.significance)."""
    out = []
    for split in dict.fromkeys(r.split for r in runs):
        rows = [Row(r.method, sum(bool(e["first_goal_success"]) for e in r.records), len(r.records),
                    int(r.metrics.get("collisions", 0)), float(r.metrics.get("distance_km", 0.0)))
                for r in runs if r.split == split]
        wanted = None if compare is None else [(a, b) for a, b in compare if {a, b} <= {row.label for row in rows}]
        if compare is not None and not wanted:
            continue
        if len(rows) > 1:
            out += [f"{SPLIT_TITLES.get(split, split)}:\n", significance_table(rows, wanted)]
    methods = {r.method for r in runs}
    for pair in compare or []:
        missing = [m for m in pair if m not in methods]
        if missing:
            raise ValueError(f"--compare names {missing[0]!r}, which is not a method of these runs: {', '.join(sorted(methods))}")
    return "\n".join(out)


def episode_tables(runs: list[Run]) -> str:
    """Every episode of every run, one collapsible table per run."""
    out = []
    for r in runs:
        out.append(f"<details><summary>{r.label}: {len(r.records)} episodes</summary>\n")
        out.append("| Episode | Scene | Goals reached | First goal | Termination | Steps | Path (m) | Collisions | d0 (m) |")
        out.append("|---|---|---:|---|---|---:|---:|---:|---:|")
        for e in r.records:
            out.append(f"| {e['episode_id']} | {e['scene_id']} | {e['goals_reached']} | "
                       f"{'yes' if e['first_goal_success'] else 'no'} | {e['termination']} | {e['steps']} | "
                       f"{e['path_length']:.2f} | {e['collisions']} | {format_metric(e.get('d0'), 2)} |")
        out.append("\n</details>\n")
    return "\n".join(out) + "\n"


def write_report(runs: list[Run], output: str | Path, title: str = "RVN benchmark results",
                 command: str | None = None, compare: list[tuple[str, str]] | None = None) -> Path:
    """Write the markdown report and its plots (next to it); returns the report's path."""
    if not runs:
        raise ValueError("no rvn-eval runs to report")
    significance = tests(runs, compare)
    out = Path(output)
    out.parent.mkdir(parents=True, exist_ok=True)
    base, stem = out.parent, out.stem
    plots = {"sr1": base / f"{stem}_sr1.png", "cpk": base / f"{stem}_cpk.png", "goals": base / f"{stem}_goals.png"}
    bar_plot(runs, "SR_1", 0, "SR_1: success rate on the first goal", "SR_1", 3, plots["sr1"], top=1.25)
    bar_plot(runs, "CPK", 2, "CPK: collisions per km (lower is better)", "collisions / km", 1, plots["cpk"], symlog=True)
    goals_plot(runs, plots["goals"])
    text = [f"# {title}\n"]
    if command:
        text.append(f"Generated by `{command}` from {len(runs)} rvn-eval run(s).\n")
    text += ["## Results (paper layout)\n", render_table([r.metrics for r in runs]),
             "\nRows *RVN (ours)* are the runs below; *(paper)* rows are the paper's table (HM3D scenes, "
             "full-scale training), for reference.\n",
             "## Ours beside the paper\n", beside_paper(runs),
             "\n## Significance\n",
             "Two-sided p-values: Fisher's exact test on first-goal successes (SR_1); the exact conditional test of "
             "two Poisson rates on collisions per km driven (CPK). Rows of the same split; a p below 0.05 marks a "
             "difference unlikely under equal rates.\n", significance,
             "\n## Runs\n", run_details(runs, base),
             "\n## Plots\n",
             f"![SR_1]({plots['sr1'].name})\n", f"![CPK]({plots['cpk'].name})\n", f"![Goals reached]({plots['goals'].name})\n",
             "\n## Episodes\n", episode_tables(runs)]
    write_text_atomic(out, "\n".join(text))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rvn_data.benchmark.report", description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="rvn-eval out_dirs (or folders holding them)")
    ap.add_argument("-o", "--output", default="report.md", help="markdown file; plots go next to it (default: report.md)")
    ap.add_argument("--title", default="RVN benchmark results")
    ap.add_argument("--compare", action="append", metavar="A=B", default=None,
                    help="test only these pairs of methods (repeatable), e.g. --compare 'NoMaD-PointGoal=Goal follower'; "
                    "default: every pair of rows of a split")
    args = ap.parse_args(argv)
    try:
        import matplotlib
        matplotlib.use("Agg")
        compare = None
        if args.compare:
            bad = [c for c in args.compare if c.count("=") != 1]
            if bad:
                raise ValueError(f"--compare {bad[0]!r}: write two method names as A=B")
            compare = [tuple(x.strip() for x in c.split("=")) for c in args.compare]
        runs = merge_shards(find_runs(args.runs))
        path = write_report(runs, args.output, args.title,
                            command="python -m rvn_data.benchmark.report " + " ".join(sys.argv[1:] if argv is None else argv),
                            compare=compare)
    except (ValueError, KeyError, OSError) as err:
        print(f"report: error: {err}", file=sys.stderr)
        return 2  # bad input (rvn_data.cli.common: 2 bad input, 1 a failed run)
    print(f"wrote {path} ({len(runs)} runs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
