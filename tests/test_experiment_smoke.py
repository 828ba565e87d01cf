"""jobs/small_experiment.sh end to end at SCALE=tiny (1 train scene × 2 trajectories, 2 training
steps per model, 1 val episode of 2 goals, one training seed: a second seed's steps, folders, labels and pairs are
tests/test_jobs_scripts.py's, the report's pooling over seeds tests/test_report.py's), its rerun (every step skipped), and
jobs/experiment_slurm.sh's commands (DRY_RUN; the rvn-gen / rvn-eval / rvn-train overrides
compose with Hydra)."""
from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import run_recipe

REPO = Path(__file__).resolve().parents[1]
PER_SEED = ("NoMaD-PointGoal", "NoMaD-PointGoal-vote", "NoMaD-Neg", "NoMaD-PointGoal-vote-veto", "NoMaD-Neg-veto",
            "NoMaD-Neg-veto-commit", "NoMaD-Neg-argmin")
METHODS = ("Random", "Oracle", "Goal follower", "Trajectory oracle", "ViNT-PointGoal", *PER_SEED)
# every row: the depth head and its veto, committed turns, the opt-in argmin row, NoMaD-PointGoal and NoMaD-Neg read
# over NoMaD-PointGoal's last two checkpoints (one a step: steps 1 and 2)
EVERY_ROW = dict(NEG_ARGMIN="1", DEPTH_AUX="0.5", DEPTH_VETO="0.5", TURN_COMMIT="1", EVAL_CHECKPOINTS="2", CKPT_EVERY="1")


def small_experiment(out: Path, **env) -> subprocess.CompletedProcess:
    return run_recipe("small_experiment.sh", out, **env)


@pytest.mark.slow
def test_tiny_experiment_end_to_end_and_rerun(tmp_path):
    out = tmp_path / "exp"
    proc = small_experiment(out, **EVERY_ROW)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    report = (out / "report.md").read_text()
    for method in METHODS:
        assert re.search(rf"^\| RVN \(ours\) \| {re.escape(method)} \|  \|  \|  \| \d\.\d{{3}} \|", report, re.M), method
        assert f"| {method} | Val |" in report
    assert "| IL (paper) | NoMaD-Neg |" in report
    for png in ("report_sr1.png", "report_cpk.png", "report_goals.png"):
        assert (out / png).is_file()
    oracle = json.loads((out / "eval" / "oracle" / "metrics.json").read_text())
    assert oracle["episodes"] == 1 and oracle["n_goals"] == 2 and oracle["SR_1"] == 1.0
    # NoMaD-Neg: NoMaD_e on the kept expert trajectories, NoMaD_n on the negatives
    kept = (out / "splits_neg" / "rvn_expert" / "train" / "traj_names.txt").read_text().split()
    assert kept == ["proc_train_0000_expert_0000"]
    for member in ("expert", "negative"):
        assert list((out / "train" / "nomad_neg" / member).glob("ckpt_*"))
    # NEG_EXPERT=reuse (default): NoMaD_e is the NoMaD-PointGoal checkpoint, not trained again
    from safetensors.torch import load_file

    def latest(d):
        return load_file(str(d / (d / "latest").read_text().strip() / "ema.safetensors"))
    adopted, source = latest(out / "train" / "nomad_neg" / "expert"), latest(out / "train" / "nomad_pointgoal" / "model")
    assert adopted.keys() == source.keys() and all(bool((adopted[k] == source[k]).all()) for k in source)
    steps = [ln.split("\t")[0] for ln in (out / "timings.tsv").read_text().splitlines()]
    assert steps[:4] == ["gen_expert", "gen_negative", "gen_val", "train_vint"]
    assert steps[9:11] == ["train_nomad", "train_nomad_neg"] and len(steps) == 21
    assert steps[14:17] == ["eval_nomad_ckpt1", "train_nomad_neg_ckpt1", "eval_nomad_neg_ckpt1"]
    trained = (out / "train" / "nomad_pointgoal" / "config.yaml").read_text()
    assert "seed: 0" in trained and "expert_from: " + str(out / "train" / "nomad_pointgoal") in \
        (out / "train" / "nomad_neg" / "config.yaml").read_text()
    # provenance: the code that made each row, in the training config, run.json, metrics.json and the report
    from rvn_data.provenance import provenance, short

    here = provenance()
    assert f"code_commit: {here['code_commit']}" in trained if here["code_commit"] else "provenance:" in trained
    for name in ("run.json", "metrics.json"):
        assert json.loads((out / "eval" / "nomad_neg" / name).read_text())["provenance"] == here
    assert f"| {short(here)} |" in report and "Warning" not in report  # one commit, one episode set
    # how goals ended, CPK outside timed-out stretches, NoMaD-Neg's CoR counts per episode
    assert "## How goals ended" in report and "cor_other_action" in report and (out / "report_ends.png").is_file()
    # training validated on the held-out val-scene expert data; the report tests the compared rows
    history = json.loads((out / "train" / "nomad_pointgoal" / "model" / "val.json").read_text())
    assert list(history) == ["2"] and 0.0 <= history["2"]["agreement"] <= 1.0
    config = (out / "train" / "nomad_pointgoal" / "config.yaml").read_text()
    assert "prediction_type: sample" in config and "pad_context: true" in config  # the small recipe's first decisions
    assert "| NoMaD-Neg | NoMaD-PointGoal |" in report and "| NoMaD-PointGoal | Goal follower |" in report
    assert "| NoMaD-Neg-veto-commit | NoMaD-Neg-veto |" in report
    committed = json.loads((out / "eval" / "nomad_neg_veto_commit" / "run.json").read_text())
    assert committed["policy"]["turn_commit"] is True and committed["policy"]["depth_veto"] == 0.5
    assert "commits" in (out / "eval" / "nomad_neg_veto_commit" / "episodes.jsonl").read_text()
    # EVAL_CHECKPOINTS=2: NoMaD-PointGoal at its checkpoint before the latest too (policy.step), and NoMaD-Neg with it
    # as NoMaD_e (train.expert_step; NoMaD_n trained again, the same weights), each read over both, compared step by step
    assert json.loads((out / "eval" / "nomad_pointgoal_ckpt1" / "run.json").read_text())["policy"]["step"] == 1
    assert "| NoMaD-PointGoal | 1, the row's |" in report and "| NoMaD-Neg | 1, the row's |" in report
    assert "| NoMaD-Neg | NoMaD-PointGoal | 2 / 2 | 1 |" in report, report
    assert "| NoMaD-Neg ckpt1 | NoMaD-PointGoal ckpt1 |" in report
    early = out / "train" / "nomad_neg_ckpt1"
    assert json.loads((early / "expert" / "ckpt_00000001" / "stats.json").read_text())["adopted_from"] == \
        str((out / "train" / "nomad_pointgoal" / "model" / "ckpt_00000001").resolve())
    a, b = latest(early / "negative"), latest(out / "train" / "nomad_neg" / "negative")
    assert a.keys() == b.keys() and all(bool((a[k] == b[k]).all()) for k in a)
    # a rerun skips every step and rewrites the same report
    again = small_experiment(out, **EVERY_ROW)
    assert again.returncode == 0, again.stderr[-3000:]
    assert again.stdout.count("done before, skipped") == 21
    assert (out / "report.md").read_text() == report


def test_bad_scale_is_refused(tmp_path):
    proc = small_experiment(tmp_path / "x", SCALE="huge")
    assert proc.returncode == 2 and "SCALE=huge" in proc.stderr and not (tmp_path / "x").exists()
    proc = small_experiment(tmp_path / "x", SCALE="tiny", PAD_CONTEXT="yes")
    assert proc.returncode == 2 and "PAD_CONTEXT=yes; choose true or false" in proc.stderr and not (tmp_path / "x").exists()
    proc = small_experiment(tmp_path / "x", SCALE="tiny", DEPTH_VETO="0.5")
    assert proc.returncode == 2 and "DEPTH_VETO=0.5 needs the depth head" in proc.stderr and not (tmp_path / "x").exists()
    proc = small_experiment(tmp_path / "x", SCALE="tiny", DEPTH_NEG_PER_SCENE="4")
    assert proc.returncode == 2 and "DEPTH_NEG_PER_SCENE=4 trains the depth head: set DEPTH_AUX > 0" in proc.stderr
    assert not (tmp_path / "x").exists()
    proc = small_experiment(tmp_path / "x", SCALE="tiny", DEPTH_AUX="0.5", DEPTH_NEG_PER_SCENE="many")
    assert proc.returncode == 2 and "DEPTH_NEG_PER_SCENE=many; give a whole number" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", NEG_ARGMIN="yes")
    assert proc.returncode == 2 and "NEG_ARGMIN=yes; choose 0 or 1" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", TURN_COMMIT="yes")
    assert proc.returncode == 2 and "TURN_COMMIT=yes; choose 0 or 1" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", TURN_COMMIT="1")
    assert proc.returncode == 2 and "TURN_COMMIT=1 adds a row to the veto's: set DEPTH_VETO" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", DEPTH_VETO_RULE="wide")
    assert proc.returncode == 2 and "DEPTH_VETO_RULE=wide; choose swept or band" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", EVAL_CHECKPOINTS="0")
    assert proc.returncode == 2 and "EVAL_CHECKPOINTS=0; give how many of NoMaD-PointGoal's last" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", CKPT_EVERY="1k")
    assert proc.returncode == 2 and "CKPT_EVERY=1k; give NoMaD-PointGoal's steps between checkpoints" in proc.stderr
    proc = small_experiment(tmp_path / "x", SCALE="tiny", SEEDS="0,1")
    assert proc.returncode == 2 and "SEEDS=0,1; give whole numbers separated by spaces" in proc.stderr
    assert not (tmp_path / "x").exists()


def _compose_check(cmd: list[str]) -> None:
    """Run a printed rvn-* command as one job with --cfg job (composition only, nothing runs)."""
    module = {"rvn-gen": "rvn_data.gen.cli", "rvn-eval": "rvn_data.benchmark.cli", "rvn-train": "rvn_il.train.cli"}[cmd[0]]
    args = []
    for a in cmd[1:]:
        if a == "-m" or a.startswith("hydra/launcher=") or a.startswith("hydra.launcher.") or a.startswith("hydra.sweep"):
            continue
        m = re.fullmatch(r"([\w.]+)=range\((\d+),.*\)", a)
        args.append(f"{m.group(1)}={m.group(2)}" if m else a)
    proc = subprocess.run([sys.executable, "-m", module, *args, "--cfg", "job"], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, f"{shlex.join(cmd)}\n{proc.stderr[-2000:]}"


def test_slurm_recipe_commands_compose(tmp_path):
    env = {**os.environ, "DRY_RUN": "1", "OUT": str(tmp_path / "rvn"), "PARTITION": "gpu"}
    proc = subprocess.run(["bash", str(REPO / "jobs" / "experiment_slurm.sh")], capture_output=True, text=True,
                          timeout=60, env=env)
    assert proc.returncode == 0, proc.stderr
    cmds = [shlex.split(ln[2:]) for ln in proc.stdout.splitlines() if ln.startswith("+ ")]
    assert not (tmp_path / "rvn").exists()  # a dry run writes nothing
    gens = [c for c in cmds if c[0] == "rvn-gen"]
    assert "trajectories_per_scene=400" in gens[0] and "trajectories_per_scene=25" in gens[1]  # 6.25 % negatives
    assert all("hydra.launcher.partition=gpu" in c for c in gens if "-m" in c)
    evals = [c for c in cmds if c[0] == "rvn-eval"]
    assert len(evals) == 3 * 6 and "episodes.first_scene=range(0,800,5)" in evals[0]
    wraps = [c for c in cmds if c[0] == "sbatch"]
    assert len(wraps) == 3 and all("train.epochs=100" in c[-1] for c in wraps)
    assert cmds[-1][:3] == ["python", "-m", "rvn_data.benchmark.report"]
    _compose_check(gens[0])
    _compose_check(evals[-1])  # test split, NoMaD-Neg with argmin
    train = shlex.split(wraps[2][-1].split("=", 1)[1])  # --wrap=torchrun ... -m rvn_il.train.cli ...
    _compose_check(["rvn-train", *train[train.index("rvn_il.train.cli") + 1:]])
