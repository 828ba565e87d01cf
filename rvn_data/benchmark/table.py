"""Results tables in the paper's layout: rows = methods, columns Train / Val / Test ×
SR_1, E(G), CPK (paper, table "RVN-Bench Results"), with the paper's numbers as
reference rows.

``python -m rvn_data.benchmark.table runs/*/*/metrics.json -o table.md`` merges several
``metrics.json`` files (one per method and split) into one table.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from rvn_data.benchmark.metrics import write_text_atomic

SPLITS = ("train", "val", "test")
SPLIT_TITLES = {"train": "Train", "val": "Val", "test": "Test"}
# Paper, table "RVN-Bench Results": (category, method) -> split -> (SR_1, E(G), CPK).
PAPER_RESULTS = {
    ("IL", "ViNT-PointGoal"): {"train": (0.097, 0.11, 442.3), "val": (0.090, 0.11, 468.3), "test": (0.093, 0.10, 465.4)},
    ("IL", "NoMaD-PointGoal"): {"train": (0.758, 4.01, 32.5), "val": (0.752, 3.69, 35.7), "test": (0.751, 4.52, 31.0)},
    ("IL", "NoMaD-Neg"): {"train": (0.750, 3.83, 31.2), "val": (0.757, 3.97, 28.6), "test": (0.760, 4.61, 25.8)},
    ("Safe-RL", "PPO-Lagrangian"): {"train": (0.826, 7.88, 15.7), "val": (0.803, 7.61, 16.9), "test": (0.805, 9.02, 13.7)},
    ("RL", "PPO"): {"train": (0.824, 8.70, 15.6), "val": (0.808, 8.54, 16.4), "test": (0.819, 8.68, 15.5)},
    ("RL", "DD-PPO"): {"train": (0.899, 13.28, 9.2), "val": (0.865, 11.86, 10.5), "test": (0.886, 13.90, 8.7)},
    ("RL", "DDPPO-DAV2"): {"train": (0.937, 20.79, 3.5), "val": (0.909, 19.88, 4.0), "test": (0.928, 20.79, 3.6)},
}


def format_metric(value: float | None, digits: int) -> str:
    """A metric for a table: fixed digits, '–' when undefined."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}f}"


def _cells(m: tuple | None) -> list[str]:
    if m is None:
        return ["", "", ""]
    sr, eg, cpk = m
    return [format_metric(sr, 3), format_metric(eg, 2), format_metric(cpk, 1)]


def collect(metrics: list[dict]) -> dict[str, dict[str, tuple]]:
    """method -> split -> (SR_1, E_G, CPK); a later file for the same method and split wins."""
    rows: dict[str, dict[str, tuple]] = {}
    for m in metrics:
        split = m.get("split")
        if split not in SPLITS:
            raise ValueError(f"metrics for {m.get('method') or m.get('policy')!r} have split={split!r}; "
                             f"expected one of {SPLITS}")
        method = str(m.get("method") or m.get("policy") or "?")
        rows.setdefault(method, {})[split] = (m["SR_1"], m["E_G"], m["CPK"])
    return rows


def render_table(metrics: list[dict], reference: bool = True) -> str:
    """Markdown table of our runs (category "RVN") and, if ``reference``, the paper's rows."""
    head = ["Category", "Method"] + [f"{SPLIT_TITLES[s]} {n}" for s in SPLITS
                                     for n in ("SR_1 ↑", "E(G) ↑", "CPK ↓")]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * 9]
    for method, by_split in collect(metrics).items():
        cells = ["RVN (ours)", method] + sum((_cells(by_split.get(s)) for s in SPLITS), [])
        lines.append("| " + " | ".join(cells) + " |")
    if reference:
        for (category, method), by_split in PAPER_RESULTS.items():
            cells = [f"{category} (paper)", method] + sum((_cells(by_split.get(s)) for s in SPLITS), [])
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def load_metrics(paths: list[str | Path]) -> list[dict]:
    out = []
    for p in paths:
        path = Path(p)
        if path.is_dir():
            path = path / "metrics.json"
        try:
            out.append(json.loads(path.read_text()))
        except FileNotFoundError:
            raise ValueError(f"metrics file {path} does not exist") from None
        except json.JSONDecodeError as err:
            raise ValueError(f"metrics file {path} is not JSON ({err.msg})") from None
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rvn_data.benchmark.table", description=__doc__.split("\n\n")[0])
    ap.add_argument("metrics", nargs="+", help="metrics.json files or rvn-eval out_dirs")
    ap.add_argument("-o", "--output", help="write the markdown here (default: stdout)")
    ap.add_argument("--no-reference", action="store_true", help="leave out the paper's rows")
    args = ap.parse_args(argv)
    try:
        text = render_table(load_metrics(args.metrics), reference=not args.no_reference)
    except (ValueError, KeyError) as err:
        print(f"table: error: {err}", file=sys.stderr)
        return 2  # bad input (rvn_data.cli.common: 2 bad input, 1 a failed run)
    if args.output:
        write_text_atomic(args.output, text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
