"""seeds.md: train.overlap false against true (and with its lag corrections, where their rows are there) over the
training seeds: each seed's rows, the spread between seeds of one arm, and the seeds pooled.

The evaluations of every pair ran on the same 200 val episodes (rvn-eval seed 0), so within a seed the two rows are
paired by episode; pooled, a unit is (training seed, episode) and the paired tests swap the rows' labels within it
(`rvn_data.benchmark.significance`): the question is whether overlap changes SR_1 or CPK whatever the seed.

    python seeds.py eval seed1/eval [...] [-o seeds.md]   # one folder of rvn-eval out_dirs per training seed, seed 0 first

The arms are those every folder holds: the third seed's pair (plain PPO and overlap + recompute) went to seeds3.md.
"""
import sys
from pathlib import Path

from rvn_data.benchmark.runs import load_run
from rvn_data.benchmark.significance import Row, significance_table

ARMS = {"false": "PPO", "true": "PPO overlap", "decoupled": "PPO overlap decoupled",  # out_dir suffix: method
        "recompute": "PPO overlap recompute"}
COMPARE = [("true", "false"), ("decoupled", "false"), ("decoupled", "true"), ("recompute", "false"),
           ("recompute", "true")]  # A against B

def row(label: str, runs: list) -> Row:
    """One row over the runs (one per seed), episodes keyed by (seed, episode id)."""
    per_episode = {(seed, e["episode_id"]): (bool(e["first_goal_success"]), int(e["collisions"]),
                                             float(e["path_length"]) / 1e3)
                   for seed, run in enumerate(runs) for e in run.records}
    return Row(label, sum(int(v[0]) for v in per_episode.values()), len(per_episode),
               sum(int(r.metrics.get("collisions", 0)) for r in runs),
               sum(float(r.metrics.get("distance_km", 0.0)) for r in runs), per_episode)


def main(folders: list[str]) -> str:
    arms = [arm for arm in ARMS if all((Path(f) / f"ppo_overlap_{arm}").is_dir() for f in folders)]
    runs = {arm: [load_run(Path(f) / f"ppo_overlap_{arm}") for f in folders] for arm in arms}
    sets = {run.episode_set for arm in arms for run in runs[arm]}
    if len(sets) != 1:
        raise SystemExit(f"the runs in {folders} were not evaluated on the same episodes ({len(sets)} episode sets)")
    compare = [(a, b) for a, b in COMPARE if a in runs and b in runs]
    out = [f"# {', '.join(ARMS[a] for a in arms)}: per training seed and pooled\n",
           f"Folders, seed 0 first: {', '.join(folders)}. Same 200 val episodes in every evaluation.\n"]

    def table(rows: dict) -> str:
        return significance_table(list(rows.values()), [(rows[a].label, rows[b].label) for a, b in compare])
    for seed, _ in enumerate(folders):
        out += [f"## Seed {seed}\n", table({arm: row(f"{ARMS[arm]} (seed {seed})", [runs[arm][seed]]) for arm in arms})]
    if len(folders) > 1:  # the same recipe across seeds: how far two seeds part without any change
        later = range(1, len(folders))
        spread = [row(f"{ARMS[arm]} (seed {seed})", [runs[arm][seed]]) for arm in arms for seed in (*later, 0)]
        pairs = [(f"{ARMS[arm]} (seed {seed})", f"{ARMS[arm]} (seed 0)") for arm in arms for seed in later]
        out += [f"## Seed spread: one arm, seed{'s' if len(later) > 1 else ''} {', '.join(map(str, later))} "
                "against seed 0\n", significance_table(spread, pairs)]
    pooled = {arm: row(f"{ARMS[arm]} (seeds 0-{len(folders) - 1})", runs[arm]) for arm in arms}
    out += ["## Seeds pooled (a unit: seed, episode)\n", table(pooled)]
    return "\n".join(out)

if __name__ == "__main__":
    args, out = sys.argv[1:], "seeds.md"
    if "-o" in args:
        i = args.index("-o")
        out, args = args[i + 1], args[:i] + args[i + 2:]
    text = main(args)
    Path(out).write_text(text)
    print(text)
