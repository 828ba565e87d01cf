"""curve_ranks.md: what the training curves (metrics.jsonl) say about the evaluation rows, over every (training seed, arm)
run in this folder: when the policy's entropy first fell below 1.0 nat (it starts at ln 4 = 1.386, four actions), its
mean over the last 40 updates, and the training episodes' collisions per km and goals reached over the last 40
updates; beside each, the run's val row (200 episodes). Spearman's rank correlation over the runs says which
training figure orders the val rows; the pairs of runs of one seed that it orders the way its rho with val CPK says (same sign) tell
whether it also orders the arms within a seed (the seeds differ as much as the arms).

    python curve_ranks.py [-o curve_ranks.md]   # from this folder
"""
import itertools
import json
import sys
from pathlib import Path

from scipy.stats import spearmanr

from rvn_rl.runlog import read_rows

HERE = Path(__file__).resolve().parent
SEEDS = {0: HERE, 1: HERE / "seed1", 2: HERE / "seed2"}
ARMS = {"false": "PPO", "true": "PPO overlap", "recompute": "PPO overlap recompute", "decoupled": "PPO overlap decoupled"}
LAST = 40  # updates: 20,480 of the runs' 122,880 env steps
FIGURES = {"entropy_below_1": "env steps to entropy < 1.0", "entropy": f"entropy, last {LAST}",
           "train_cpk": f"train CPK, last {LAST}", "train_goals": f"train goals / episode, last {LAST}"}


def run_figures(folder: Path, arm: str) -> dict | None:
    rows = read_rows(folder / "train" / f"ppo_overlap_{arm}")
    if not rows:
        return None
    last = rows[-LAST:]

    def mean(key: str) -> float:
        return sum(r[key] for r in last) / len(last)

    val = json.loads((folder / "eval" / f"ppo_overlap_{arm}" / "metrics.json").read_text())
    return {"entropy_below_1": next((r["env_steps"] for r in rows if r["entropy"] < 1.0), None),
            "entropy": mean("entropy"), "train_cpk": mean("collisions_per_km"), "train_goals": mean("goals"),
            "SR_1": val["SR_1"], "CPK": val["CPK"], "env_steps": rows[-1]["env_steps"]}


def main() -> str:
    runs = {(s, a): f for s, folder in SEEDS.items() for a in ARMS if (f := run_figures(folder, a)) is not None}
    out = ["# Training curves against the val rows (every training seed and arm)\n",
           f"{len(runs)} runs of {next(iter(runs.values()))['env_steps']:,} env steps; the val rows on the same 200 "
           "episodes. Written by curve_ranks.py.\n",
           "| seed | arm | " + " | ".join(FIGURES.values()) + " | val SR_1 | val CPK |",
           "|---|---|" + "---:|" * (len(FIGURES) + 2)]
    for (s, a), f in sorted(runs.items(), key=lambda kv: (kv[0][0], list(ARMS).index(kv[0][1]))):
        out.append(f"| {s} | {ARMS[a]} | {f['entropy_below_1']:,} | {f['entropy']:.3f} | {f['train_cpk']:.0f} | "
                   f"{f['train_goals']:.3f} | {f['SR_1']:.3f} | {f['CPK']:.0f} |")
    out += ["", "Spearman's rho over the runs (p, two-sided):", "",
            "| training figure | val CPK | val SR_1 | pairs within a seed ordered as its rho with val CPK says |", "|---|---:|---:|---:|"]
    for key, name in FIGURES.items():
        tests = [spearmanr([f[key] for f in runs.values()], [f[target] for f in runs.values()])
                 for target in ("CPK", "SR_1")]
        cells = [f"{rho:+.2f} ({p:.3f})" for rho, p in tests]
        sign = 1.0 if tests[0][0] >= 0 else -1.0  # the direction of its rho with val CPK
        pairs = [(a, b) for a, b in itertools.combinations(runs, 2) if a[0] == b[0]]
        alike = sum(sign * (runs[a][key] - runs[b][key]) * (runs[a]["CPK"] - runs[b]["CPK"]) > 0 for a, b in pairs)
        out.append(f"| {name} | {' | '.join(cells)} | {alike} of {len(pairs)} |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    text = main()
    if sys.argv[1:2] == ["-o"] and len(sys.argv) == 3:
        Path(sys.argv[2]).write_text(text)
    elif sys.argv[1:]:
        raise SystemExit("usage: python curve_ranks.py [-o curve_ranks.md]")
    print(text, end="")
