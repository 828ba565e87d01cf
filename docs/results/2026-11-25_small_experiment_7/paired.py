"""Paired comparison of rvn-eval rows scored on the same episodes (run 7, issue 15).

    python docs/results/2026-11-25_small_experiment_7/paired.py REF_DIR ROW_DIR [ROW_DIR ...]

For each row: SR_1, the first-goal failures by collision within the first 3 and 10 steps of an
episode (the decisions made on a context padded with the first frame are the first 3), and
against REF (same episode ids): episodes won and lost, McNemar's exact test on them (binomial
on the discordant pairs), Fisher's exact test on the two SR_1 counts.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from scipy.stats import binomtest, fisher_exact


def load(run: str) -> dict[str, dict]:
    records = [json.loads(line) for line in (Path(run) / "episodes.jsonl").read_text().splitlines() if line.strip()]
    return {r["episode_id"]: r for r in records}


def early_collisions(rows: dict[str, dict], within: int) -> int:
    return sum(1 for r in rows.values() if not r["first_goal_success"] and r["termination"] == "collision"
               and r["goals"][0]["steps"] <= within)


def main(ref_dir: str, *row_dirs: str) -> None:
    ref = load(ref_dir)
    n = len(ref)
    print(f"{'row':<44}{'SR_1':>6}{'coll<=3':>9}{'coll<=10':>9}{'won':>5}{'lost':>5}{'McNemar p':>11}{'Fisher p':>10}")
    for d in (ref_dir, *row_dirs):
        rows = load(d)
        if set(rows) != set(ref):
            raise SystemExit(f"{d}: not the episodes of {ref_dir}")
        won = sum(rows[k]["first_goal_success"] and not ref[k]["first_goal_success"] for k in ref)
        lost = sum(ref[k]["first_goal_success"] and not rows[k]["first_goal_success"] for k in ref)
        s, s_ref = (sum(r["first_goal_success"] for r in x.values()) for x in (rows, ref))
        mcnemar = binomtest(won, won + lost).pvalue if won + lost else 1.0
        fisher = fisher_exact([[s, n - s], [s_ref, n - s_ref]]).pvalue
        print(f"{Path(d).name:<44}{s / n:>6.3f}{early_collisions(rows, 3):>9}{early_collisions(rows, 10):>9}"
              f"{won:>5}{lost:>5}{mcnemar:>11.3f}{fisher:>10.3f}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])
