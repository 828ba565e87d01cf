"""How the first goal of each episode ends, per rvn-eval row (run 8, issue 15).

    python docs/results/2026-11-25_small_experiment_8/failures.py ROW_DIR [ROW_DIR ...]

Per row: goals reached over the whole run, first goals failed by collision and by timeout, the median step of a
failed first goal's end, and the km driven with the collisions on the way (CPK's terms).
"""
from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path


def main(*rows: str) -> None:
    print(f"{'row':<40}{'goals':>7}{'fail coll':>10}{'fail time':>10}{'median step':>12}{'km':>7}{'colls':>7}")
    for d in rows:
        eps = [json.loads(line) for line in (Path(d) / "episodes.jsonl").read_text().splitlines() if line.strip()]
        failed = [e for e in eps if not e["first_goal_success"]]
        metrics = json.loads((Path(d) / "metrics.json").read_text())
        reached = sum(e["goals_reached"] for e in eps)
        print(f"{Path(d).name:<40}{reached:>7}{sum(e['termination'] == 'collision' for e in failed):>10}"
              f"{sum(e['termination'] != 'collision' for e in failed):>10}"
              f"{statistics.median(e['goals'][0]['steps'] for e in failed):>12.1f}"
              f"{metrics['distance_km']:>7.2f}{metrics['collisions']:>7}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])
