"""The comparisons these folders make with each training seed, pooled over both seeds: every episode of seed 0's
pair and of seed 1's pair is one paired observation (keyed by seed and episode), tested as report.md tests one pair
(rvn_data.benchmark.significance.paired: McNemar on first goals, bootstrap CPK ratio, paired randomisation test).
Run from this folder after assemble.sh (and the other folders' assemble.sh):  python pooled.py > pooled.md"""
from pathlib import Path

from rvn_data.benchmark.report import row_of
from rvn_data.benchmark.runs import load_run
from rvn_data.benchmark.significance import format_p, paired, pool_rows

HERE = Path(__file__).resolve().parent
R = HERE.parent
# (what is compared, [(A, B) for seed 0, (A, B) for seed 1])
PAIRS = [
    ("NoMaD-Neg / NoMaD-PointGoal", [(R / "2026-12-05_escape/eval/nomad_neg", R / "2026-12-05_escape/eval/nomad_pointgoal"),
                                     (R / "2026-12-05_neg_seed1/eval/nomad_neg", R / "2026-12-05_neg_seed1/eval/nomad_pointgoal")]),
    ("NoMaD-Neg-argmin / NoMaD-PointGoal", [(HERE / "eval/nomad_neg_argmin", R / "2026-12-05_escape/eval/nomad_pointgoal"),
                                            (HERE / "eval/nomad_neg_argmin_seed1", R / "2026-12-05_neg_seed1/eval/nomad_pointgoal")]),
    ("NoMaD-Neg-veto / NoMaD-PointGoal-veto", [(R / "2026-12-05_escape/eval/nomad_neg_veto", HERE / "eval/nomad_pointgoal_veto"),
                                               (R / "2026-12-05_neg_seed1/eval/nomad_neg_veto", HERE / "eval/nomad_pointgoal_veto_seed1")]),
    ("NoMaD-PointGoal-veto / NoMaD-PointGoal", [(HERE / "eval/nomad_pointgoal_veto", R / "2026-12-05_escape/eval/nomad_pointgoal"),
                                                (HERE / "eval/nomad_pointgoal_veto_seed1", R / "2026-12-05_neg_seed1/eval/nomad_pointgoal")]),
    ("NoMaD-Neg-veto-commit / NoMaD-Neg-veto", [(R / "2026-12-05_turn_commit/eval/nomad_neg_veto_commit", R / "2026-12-05_escape/eval/nomad_neg_veto"),
                                                (R / "2026-12-06_turn_commit_seed1/eval/nomad_neg_veto_commit", R / "2026-12-05_neg_seed1/eval/nomad_neg_veto")]),
]


def pooled_row(label: str, folders: list[Path]):
    return pool_rows(label, {f"seed{seed}": row_of(load_run(folder)) for seed, folder in enumerate(folders)})


def main() -> None:
    print("| A / B, both seeds pooled (400 paired episodes) | SR_1 A | SR_1 B | won–lost, McNemar p | CPK A | CPK B "
          "| CPK A / B [95 % CI], paired p |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for what, pairs in PAIRS:
        a, b = (pooled_row(label, [p[i] for p in pairs]) for i, label in enumerate(what.split(" / ")))
        t = paired(a, b)
        lo, hi = t["cpk_ratio_ci"]
        print(f"| {what} | {a.sr1:.3f} | {b.sr1:.3f} | {t['won']}–{t['lost']}, {format_p(t['mcnemar_p'])} "
              f"| {a.cpk:.1f} | {b.cpk:.1f} | {t['cpk_ratio']:.2f} [{lo:.2f}, {hi:.2f}], {format_p(t['cpk_paired_p'])} |")


if __name__ == "__main__":
    main()
