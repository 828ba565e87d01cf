"""Results report (markdown + PNG plots) from rvn-eval output directories.

    python -m rvn_data.benchmark.report RUN_DIR [RUN_DIR ...] -o report.md [--title TEXT]

Each RUN_DIR is an rvn-eval ``out_dir`` (``metrics.json`` + ``episodes.jsonl`` + ``run.json``; one
per policy × split) or a folder searched for them. A row is one run identity (`rvn_data.benchmark.runs`:
recorded settings, checkpoint digest, commit), never a method label alone; shards of one evaluation
(e.g. over ``episodes.first_scene``) are merged, their metrics recomputed from all records. A line
above the table flags rows from different commits or episode sets. The report holds the results table in the paper's
layout (`rvn_data.benchmark.table`, paper rows included), our numbers beside the paper's per
method and split, run details with links to the per-episode logs, plots written next to
the report (``<stem>_sr1.png``, ``<stem>_cpk.png``, ``<stem>_goals.png``, ``<stem>_ends.png``: how
goals ended), how goals ended with CPK over all kilometres and outside timed-out stretches, significance tests between rows (each
compared pair also pooled over training seeds where the rows of other seeds, labelled ``"<method> seed<s>"`` as the
recipes do, are there: `rvn_data.benchmark.significance.pooled_pairs`; and each row read over its run's checkpoints
where rows ``"<method> ckpt<step>"`` of its other checkpoints are there (RL: env steps, IL: training steps:
`over_checkpoints`), and every episode's record. Runs appear in the order given.
"""
from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from itertools import combinations
from pathlib import Path

from rvn_data.benchmark.metrics import TERMINATIONS, write_text_atomic
from rvn_data.benchmark.plots import bar_plot, ends_plot, goals_plot
from rvn_data.benchmark.results import episode_key
from rvn_data.benchmark.runs import Run, find_runs, load_run, merge_shards, provenance_note  # noqa: F401 (API)
from rvn_data.benchmark.significance import (SEED_LABEL, Row, checkpoint_table, mean_pairs_table, over_checkpoints,
                                             pooled_table, significance_table)
from rvn_data.benchmark.table import SPLIT_TITLES, format_metric, render_table

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
    """Markdown table of each run's set-up, secondary metrics, terminations and log path (and its maps of the
    episodes' paths, where rvn-eval ran with paths=true)."""
    lines = ["| Method | Policy | Split | Scenes × episodes | N_goal | Episodes | SPL_1 | Path/episode (m) | "
             "Collisions | Steps | " + " / ".join(TERMINATIONS) + " | Commit | Generator | Episode set | Per-episode log |",
             "|---|---|---|---|---:|---:|---:|---:|---:|---:|---|---|---|---|---|"]
    for r in runs:
        m = r.metrics
        ends = Counter(rec["termination"] for rec in r.records)
        dirs = r.shards or [r.dir]
        logs = ", ".join(f"[{x}]({x})" for x in (_rel(d / "episodes.jsonl", base) for d in dirs))
        maps = [_rel(d / "maps", base) for d in dirs if any((d / "maps").glob("*.png"))]  # rvn-eval paths=true
        logs += "".join(f", [maps]({x}/)" for x in maps)
        lines.append(f"| {r.method} | {m.get('policy', '')} | {r.split} | {m.get('scenes', '?')} × {m.get('per_scene', '?')} "
                     f"| {m.get('n_goals', '?')} | {m['episodes']} | {format_metric(m.get('SPL_1'), 3)} "
                     f"| {format_metric(m.get('path_length'), 2)} | {m.get('collisions', '')} | {m.get('steps', '')} "
                     f"| {' / '.join(str(ends.get(t, 0)) for t in TERMINATIONS)} | {', '.join(r.commits)} "
                     f"| {(r.provenance or {}).get('generator_version', '?')} | {r.episode_set} | {logs} |")
    return "\n".join(lines) + "\n"


def goal_endings(runs: list[Run]) -> str:
    """Markdown table: how each row's goals ended, CPK over all km (the paper's) and outside timed-out
    stretches, the share of turns in place among the actions of the timed-out stretches (a policy that
    spins rather than drives), and what the policy counted (e.g. depth vetoes) per episode."""
    lines = ["| Method | Split | Goals attempted | Success | Collision | Timeout | Episodes timed out | "
             "km (in timed-out stretches) | Turns in timed-out stretches | CPK | CPK excl. timeouts | Policy counts per episode |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in runs:
        m, ends = r.metrics, r.metrics["goal_ends"]
        total = sum(ends.values()) or 1
        km_out = sum(float(e["goals"][-1]["path_length"]) for e in r.records if e["termination"] == "timeout" and e["goals"]) / 1e3
        share = [f"{ends[t] / total:.1%} ({ends[t]})" for t in ("success", "collision", "timeout")]
        counts = ", ".join(f"{k} {v / m['episodes']:.1f}" for k, v in sorted((m.get("policy_stats") or {}).items()))
        acts = [e["goals"][-1].get("actions") for e in r.records if e["termination"] == "timeout" and e["goals"]]
        acts = [a for a in acts if a]
        turns = f"{sum(a[2] + a[3] for a in acts) / max(1, sum(map(sum, acts))):.0%}" if acts else "–"
        lines.append(f"| {r.method} | {r.split} | {sum(ends.values())} | {' | '.join(share)} | {ends['timeout']} "
                     f"| {m['distance_km']:.2f} ({km_out:.2f}) | {turns} | {format_metric(m['CPK'], 1)} "
                     f"| {format_metric(m['CPK_excl_timeout'], 1)} | {counts} |")
    return "\n".join(lines) + "\n"


def row_of(run: Run) -> Row:
    """What the significance tests need of one run: its totals and, per episode, (first goal reached, collisions, km)."""
    return Row(run.method, sum(bool(e["first_goal_success"]) for e in run.records), len(run.records),
               int(run.metrics.get("collisions", 0)), float(run.metrics.get("distance_km", 0.0)),
               {episode_key(e): (bool(e["first_goal_success"]), int(e["collisions"]), float(e["path_length"]) / 1e3)
                for e in run.records})


def tests(runs: list[Run], compare: list[tuple[str, str]] | None = None, compare_present: bool = False) -> str:
    """Significance of the differences between rows of the same split (rvn_data.benchmark.significance).

    A compared pair naming a method that no run has is refused (a typo), or with ``compare_present`` left out of the
    tests and listed (a partial run's report, where some rows are not there yet)."""
    out = []
    methods = {r.method for r in runs}
    absent = [pair for pair in compare or [] if not set(pair) <= methods]
    if absent and not compare_present:
        missing = next(m for m in absent[0] if m not in methods)
        raise ValueError(f"--compare names {missing!r}, which is not a method of these runs: {', '.join(sorted(methods))}"
                         " (--compare-present leaves such pairs out)")
    if absent:
        compare = [pair for pair in compare if pair not in absent]
    for split in dict.fromkeys(r.split for r in runs):
        rows = [row_of(r) for r in runs if r.split == split]
        wanted = None if compare is None else [(a, b) for a, b in compare if {a, b} <= {row.label for row in rows}]
        if compare is not None and not wanted:
            continue
        if len(rows) > 1:
            out += [f"{SPLIT_TITLES.get(split, split)}:\n", significance_table(rows, wanted)]
            pooled = pooled_table(rows, wanted)
            if pooled:  # rows of other training seeds ("<method> seed<s>") beside the compared ones
                out += [f"{SPLIT_TITLES.get(split, split)}, pooled over training seeds (each pair above with its rows of "
                        "other seeds, \"<method> seed<s>\"; every seed's episodes paired with the same seed's):\n", pooled]
            out += over_checkpoints_tests(rows, wanted, SPLIT_TITLES.get(split, split))
    if compare_present and absent:
        out.append("Not tested (a row is not among these runs): " + ", ".join(f"{a} = {b}" for a, b in absent) + ".\n")
    return "\n".join(out)


def over_checkpoints_tests(rows: list[Row], wanted: list[tuple[str, str]] | None, title: str) -> list[str]:
    """The tests again with each row that has rows of its run's other checkpoints ("<method> ckpt<step>") read
    as their mean (`significance.over_checkpoints`): the rows one by one, each pair with such a row, and those pairs
    pooled over training seeds. Nothing where no row has them."""
    means, groups = over_checkpoints(rows)
    if not groups:
        return []
    labels = [r.label for r in means]
    read = set(groups) | {m["base"] for g in groups if (m := SEED_LABEL.match(g))}  # "A" too for its "A seed<s>"
    touched = [(a, b) for a, b in (combinations(labels, 2) if wanted is None else wanted)
               if a in labels and b in labels and (a in read or b in read)]
    out = [f"{title}, each row read over its run's checkpoints (rows \"<method> ckpt<step>\" beside it, on the "
           "same episodes: per episode the share of the checkpoints that reached the first goal; won–lost sums the "
           "per-episode differences in that share, p a paired randomisation test on them):\n", checkpoint_table(groups),
           mean_pairs_table(means, groups, touched)]
    pooled = pooled_table(means, touched)
    if pooled:
        out += [f"{title}, read over checkpoints and pooled over training seeds:\n", pooled]
    return out


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
                 command: str | None = None, compare: list[tuple[str, str]] | None = None,
                 compare_present: bool = False) -> Path:
    """Write the markdown report and its plots (next to it); returns the report's path."""
    if not runs:
        raise ValueError("no rvn-eval runs to report")
    significance = tests(runs, compare, compare_present)
    out = Path(output)
    out.parent.mkdir(parents=True, exist_ok=True)
    base, stem = out.parent, out.stem
    plots = {"sr1": base / f"{stem}_sr1.png", "cpk": base / f"{stem}_cpk.png", "goals": base / f"{stem}_goals.png",
             "ends": base / f"{stem}_ends.png"}
    bar_plot(runs, "SR_1", 0, "SR_1: success rate on the first goal", "SR_1", 3, plots["sr1"], top=1.25)
    bar_plot(runs, "CPK", 2, "CPK: collisions per km (lower is better)", "collisions / km", 1, plots["cpk"], symlog=True)
    goals_plot(runs, plots["goals"])
    ends_plot(runs, plots["ends"])
    text = [f"# {title}\n"]
    if command:
        text.append(f"Generated by `{command}` from {len(runs)} rvn-eval run(s).\n")
    text += ["## Results (paper layout)\n", provenance_note(runs), render_table([{**r.metrics, "method": r.method} for r in runs]),
             "\nRows *RVN (ours)* are the runs below; *(paper)* rows are the paper's table (HM3D scenes, "
             "full-scale training), for reference.\n",
             "## Ours beside the paper\n", beside_paper(runs),
             "\n## How goals ended\n",
             "A goal ends in success (reached), or with the episode: a collision or a timeout (T_max steps without "
             "reaching it). CPK counts every kilometre (the paper's); *CPK excl. timeouts* leaves out the stretches "
             "driven towards a goal that then timed out, where a policy that stalls or circles drives collision-free.\n",
             goal_endings(runs),
             "\n## Significance\n",
             "Two-sided p-values: Fisher's exact test on first-goal successes (SR_1); the exact conditional test of "
             "two Poisson rates on collisions per km driven (CPK). Rows on the same episodes are also compared pair by "
             "pair: McNemar's exact test on the episodes only one row succeeds on (won–lost), and the CPK ratio with a "
             "95 % bootstrap interval and a paired randomisation test (labels swapped per episode). Rows of the same "
             "split; a p below 0.05 marks a difference unlikely under equal rates.\n", significance,
             "\n## Runs\n", run_details(runs, base),
             "\n## Plots\n",
             f"![SR_1]({plots['sr1'].name})\n", f"![CPK]({plots['cpk'].name})\n", f"![Goals reached]({plots['goals'].name})\n",
             f"![How goals ended]({plots['ends'].name})\n",
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
    ap.add_argument("--compare-present", action="store_true",
                    help="leave out (and list) --compare pairs naming a method none of the runs has, e.g. a partial "
                    "run's rows; default: refuse them as typos")
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
                            compare=compare, compare_present=args.compare_present)
    except (ValueError, KeyError, OSError) as err:
        print(f"report: error: {err}", file=sys.stderr)
        return 2  # bad input (rvn_data.cli.common: 2 bad input, 1 a failed run)
    print(f"wrote {path} ({len(runs)} runs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
