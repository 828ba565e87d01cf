"""The Slurm job recipes (jobs/*.sh) run with stub commands on PATH: what they call, with which arguments, and what
they do when a call fails. The stubs log each call (one line, shell-quoted) and answer as told by the environment."""
from __future__ import annotations

import os
import shlex
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MODULES = {"rvn-gen": "rvn_data.gen.cli", "rvn-eval": "rvn_data.benchmark.cli", "rvn-train": "rvn_il.train.cli"}


def stub(bin_dir: Path, name: str, body: str = "") -> None:
    """``bin_dir/name``: appends its command line to $CALLS, then runs ``body`` (bash; exit 0 by default)."""
    bin_dir.mkdir(exist_ok=True)
    path = bin_dir / name
    # one write a call (O_APPEND): calls from background jobs do not interleave
    path.write_text(f'#!/usr/bin/env bash\nline=$(printf "%q " {name} "$@"); printf "%s\\n" "$line" >>"$CALLS"\n{body}\n')
    path.chmod(0o755)


def compose_only(name: str) -> str:
    """A stub body that checks a plain (not -m) call's overrides as the real command composes them (--cfg job:
    nothing runs), exiting with its status; a multirun call exits with $MULTIRUN_STATUS (0 unless set)."""
    return (f'if [[ "$1" == -m ]]; then exit "${{MULTIRUN_STATUS:-0}}"; fi\n'
            f'exec {shlex.quote(sys.executable)} -m {MODULES[name]} "$@" --cfg job >/dev/null')


def run_script(script: str, tmp_path: Path, *args: str, **env: str) -> tuple[subprocess.CompletedProcess, list[list[str]]]:
    """``bash jobs/<script> ARGS`` with tmp_path/bin first on PATH; returns the process and the stubs' calls."""
    calls = tmp_path / "calls.txt"
    calls.write_text("")
    full = {**os.environ, "PATH": f"{tmp_path / 'bin'}{os.pathsep}{os.environ['PATH']}", "CALLS": str(calls),
            "OUT": str(tmp_path / "out"), **env}
    # output to files, not pipes: the call returns when bash exits, not when the last process holding its output does
    with open(tmp_path / "stdout.txt", "w+") as out, open(tmp_path / "stderr.txt", "w+") as err:
        rc = subprocess.run(["bash", str(REPO / "jobs" / script), *args], stdout=out, stderr=err, timeout=300,
                            env=full, cwd=tmp_path, stdin=subprocess.DEVNULL).returncode
        out.seek(0), err.seek(0)
        proc = subprocess.CompletedProcess([script, *args], rc, out.read(), err.read())
    return proc, [shlex.split(ln) for ln in calls.read_text().splitlines() if ln.strip()]


def test_gen_paper_scale_gives_launcher_settings_to_the_multirun_only(tmp_path):
    """jobs/README.md's `hydra.launcher.partition=gpu`: the multirun takes it; merge, a plain run on the basic
    launcher, would refuse it (exit 2) and the negative dataset would never be generated."""
    stub(tmp_path / "bin", "rvn-gen", compose_only("rvn-gen"))
    proc, calls = run_script("gen_paper_scale.sh", tmp_path, "hydra.launcher.partition=gpu", "workers=8")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert [(c[1], c[c.index("dataset=expert") if "dataset=expert" in c else c.index("dataset=negative")])
            for c in calls] == [("-m", "dataset=expert"), ("mode=merge", "dataset=expert"),
                                ("-m", "dataset=negative"), ("mode=merge", "dataset=negative")]
    for c in calls:
        assert "workers=8" in c
        assert ("hydra.launcher.partition=gpu" in c) == (c[1] == "-m"), c


def test_slurm_tasks_get_the_cpus_they_asked_for(tmp_path):
    """Slurm 22.05-23.02: srun does not inherit sbatch's --cpus-per-task, so submitit's bare srun (and the recipe's
    torchrun step) would run each task on one CPU; the launcher's setup exports SRUN_CPUS_PER_TASK and
    rl_paper_scale.sh gives srun the CPUs itself."""
    from hydra import compose, initialize_config_dir

    from rvn_data.config import CONF_DIR, register_configs

    register_configs()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose(config_name="gen", overrides=["hydra/launcher=slurm"], return_hydra_config=True)
    assert "export SRUN_CPUS_PER_TASK=$SLURM_CPUS_PER_TASK" in list(cfg.hydra.launcher.setup or [])
    proc = subprocess.run(["bash", str(REPO / "jobs" / "rl_paper_scale.sh")], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "DRY_RUN": "1", "OUT": str(tmp_path / "out"), "DEPTH_SOURCE": "true",
                               "GPUS": "2"})
    assert proc.returncode == 0, proc.stderr
    sruns = [ln for ln in proc.stdout.splitlines() if "torchrun" in ln]
    assert len(sruns) == 2 and all(ln.startswith("srun --cpus-per-task=16 torchrun ") for ln in sruns), sruns


def test_paper_scale_datasets_put_every_train_scene_in_the_train_split(tmp_path):
    """rvn-gen's dataset.train_fraction defaults to 0.8: the paper-scale recipes would train on 640 of the 800 train
    scenes (256k of the promised 320k trajectories). Every rvn-gen call of theirs, merge too, says 1.0."""
    stub(tmp_path / "bin", "rvn-gen", compose_only("rvn-gen"))
    proc, calls = run_script("gen_paper_scale.sh", tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert len(calls) == 4 and all("dataset.train_fraction=1.0" in c for c in calls), calls
    proc = subprocess.run(["bash", str(REPO / "jobs" / "experiment_slurm.sh")], capture_output=True, text=True,
                          timeout=60, env={**os.environ, "DRY_RUN": "1", "OUT": str(tmp_path / "rvn")})
    assert proc.returncode == 0, proc.stderr
    gens = [shlex.split(ln[2:]) for ln in proc.stdout.splitlines() if ln.startswith("+ rvn-gen")]
    assert len(gens) == 4 and all("dataset.train_fraction=1.0" in c for c in gens), gens


def lib_recipe(tmp_path: Path, body: str) -> tuple[Path, Path]:
    """A recipe ``tmp_path/recipe.sh`` that sources jobs/lib.sh with OUT = ``tmp_path/out`` (made, as the recipes make
    it) and runs ``body``; returns the recipe and OUT."""
    out = tmp_path / "out"
    (out / "logs").mkdir(parents=True)
    (out / ".done").mkdir()
    recipe = tmp_path / "recipe.sh"
    recipe.write_text(f'set -euo pipefail\nOUT={out}\nsource {REPO / "jobs" / "lib.sh"}\n{body}')
    return recipe, out


def test_a_step_that_ran_makes_every_later_step_run(tmp_path):
    """jobs/lib.sh's `step`: an unchanged prefix of steps is skipped; after a step that ran (changed command, or one
    that never finished), every later step runs too, unchanged or not: an evaluation after its model was retrained
    must not keep the old model's numbers, also when the run that retrained it was stopped before the evaluation."""
    recipe, _ = lib_recipe(tmp_path, 'step gen work gen "${GEN:-1}"\nstep train work train "${EPOCHS:-1}"\n'
                                     'step eval work eval\nstep report work report\n')
    stub(tmp_path / "bin", "work", 'if [[ "$1" == "${FAIL:-}" ]]; then exit 1; fi')

    def ran(**env) -> list[str]:
        proc, calls = run_script(str(recipe), tmp_path, **env)
        assert proc.returncode == (1 if env.get("FAIL") else 0), proc.stderr
        return [c[1] for c in calls]

    assert ran() == ["gen", "train", "eval", "report"]
    assert ran() == []
    assert ran(EPOCHS="4") == ["train", "eval", "report"]  # retrained: evaluated again
    assert ran(EPOCHS="4") == []
    assert ran(EPOCHS="8", FAIL="eval") == ["train", "eval"]  # stopped after retraining
    assert ran(EPOCHS="8") == ["eval", "report"]
    assert ran(EPOCHS="8") == []


def test_steps_run_in_background_count_in_the_runs_seconds(tmp_path):
    """jobs/lib.sh's STEPS_SECONDS (a recipe's "s in steps run now"): steps run side by side in background subshells
    count once `step_seen` meets them after `wait`, as a step run in the foreground does; a rerun that skips them all
    counts nothing."""
    recipe, out = lib_recipe(tmp_path, 'step gen work gen\n( step train_a work a ) & a=$!\n'
                                       '( step train_b work b ) & b=$!\nwait $a; wait $b\nstep_seen train_a train_b\n'
                                       'step eval work eval\necho "steps: $STEPS_SECONDS"\n')
    stub(tmp_path / "bin", "work", "sleep 1")

    def steps_seconds() -> int:
        proc, _ = run_script(str(recipe), tmp_path)
        assert proc.returncode == 0, proc.stderr
        return int(proc.stdout.strip().splitlines()[-1].removeprefix("steps: "))

    first = steps_seconds()
    timed = dict(line.split("\t") for line in (out / "timings.tsv").read_text().splitlines())
    assert sorted(timed) == ["eval", "gen", "train_a", "train_b"]
    assert first == sum(int(s) for s in timed.values()) >= 4
    assert steps_seconds() == 0  # all skipped
    assert not list((out / ".done").glob("*.seconds"))


def rl_small_stubs(tmp_path: Path) -> dict[str, str]:
    """Stub rvn-rl, rvn-eval and the report's python for jobs/rl_small.sh; an rvn-rl whose first argument is
    $FAIL_ALGO fails after a moment, one whose first is $SLOW_ALGO trains until killed (its pid in $SLOW_PID)."""
    stub(tmp_path / "bin", "rvn-rl", 'if [[ "$1" == "${FAIL_ALGO:-}" ]]; then sleep 1; exit 1; fi\n'
                                     'if [[ "$1" == "${SLOW_ALGO:-}" ]]; then echo $$ >"$SLOW_PID"; exec sleep 60; fi')
    stub(tmp_path / "bin", "rvn-eval")
    stub(tmp_path / "bin", "python")
    return {"PYTHON": "python", "SCALE": "tiny"}



def recorded_evals(out: Path, runs: list[str]) -> None:
    """Evaluations recorded in docs/results (``<folder after 2026-12-06_>/eval/<run>``) copied into ``out/eval/<run>``
    beside the blind goal follower's, on the same 200 val episodes: the stub rvn-eval leaves them as they are."""
    import shutil

    results = REPO / "docs" / "results"
    for run in ["rl_main/eval/goal_follower_stoprule", *runs]:
        name = "goal_follower" if run.endswith("goal_follower_stoprule") else Path(run).name
        shutil.copytree(results / f"2026-12-06_{run}", out / "eval" / name)

def test_rl_small_evaluates_again_after_a_training_ran(tmp_path):
    """rl_small.sh trains PPO and PPO-Lagrangian in background subshells: a training that ran there must make the
    evaluations after it run again too."""
    env = rl_small_stubs(tmp_path)
    out = str(tmp_path / "rl")
    proc, calls = run_script("rl_small.sh", tmp_path, out, **env)
    assert proc.returncode == 0, proc.stderr
    assert sorted(c[0] for c in calls) == ["python"] + ["rvn-eval"] * 3 + ["rvn-rl"] * 2
    proc, calls = run_script("rl_small.sh", tmp_path, out, **env, COST_LIMIT="1e-3")
    assert proc.returncode == 0, proc.stderr
    assert [c[:2] for c in calls if c[0] == "rvn-rl"] == [["rvn-rl", "algo=ppo_lag"]]
    assert len([c for c in calls if c[0] == "rvn-eval"]) == 3


def test_rl_small_trains_a_tagged_variant_beside_the_runs_it_keeps(tmp_path):
    """RL_EXTRA passes more rvn-rl overrides (env.stop_far_is_failure=true); with TAG the variant trains and is
    evaluated in run folders of its own, under its own label, beside the untagged runs of the same OUT (their caches
    and val episodes). Without TAG, where OUT holds an untagged run, it is refused: rvn-rl would continue that run."""
    env = rl_small_stubs(tmp_path)
    out = tmp_path / "rl"
    proc, _ = run_script("rl_small.sh", tmp_path, str(out), **env, ALGOS="ppo_lag")
    assert proc.returncode == 0, proc.stderr
    (out / "train" / "ppo_lag").mkdir(parents=True)  # the stub trains nothing
    extra = {"ALGOS": "ppo_lag", "RL_EXTRA": "env.stop_far_is_failure=true"}
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, **extra)
    assert proc.returncode == 2 and not calls, proc.stderr
    assert "RL_EXTRA='env.stop_far_is_failure=true' would continue" in proc.stderr and "TAG" in proc.stderr
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, **extra, TAG="a b")
    assert proc.returncode == 2 and "TAG='a b'" in proc.stderr and not calls, proc.stderr
    done = (out / ".done" / "train_ppo_lag").read_text()
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, **extra, TAG="stop_far")
    assert proc.returncode == 0, proc.stderr
    [train] = [c for c in calls if c[0] == "rvn-rl"]
    assert f"out_dir={out}/train/ppo_lag_stop_far" in train and train[-1] == "env.stop_far_is_failure=true"
    evals = {c[c.index("policy=checkpoint") + 2]: c for c in calls if "policy=checkpoint" in c}
    assert list(evals) == ["method=PPO-Lagrangian stop_far"]
    assert f"out_dir={out}/eval/ppo_lag_stop_far" in evals["method=PPO-Lagrangian stop_far"]
    assert (out / ".done" / "train_ppo_lag").read_text() == done and (out / ".done" / "train_ppo_lag_stop_far").exists()


def test_rl_small_trains_another_seed_on_the_same_val_episodes(tmp_path):
    """TRAIN_SEED seeds the trainings alone: a second training seed (TAG=seed1) is evaluated on SEED's val episodes."""
    env = rl_small_stubs(tmp_path)
    out = tmp_path / "rl"
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, TRAIN_SEED="1", TAG="seed1")
    assert proc.returncode == 0, proc.stderr
    trains = [c for c in calls if c[0] == "rvn-rl"]
    evals = [c for c in calls if c[0] == "rvn-eval"]
    assert len(trains) == 2 and all("seed=1" in c and "seed=0" not in c for c in trains)
    assert len(evals) == 3 and all("seed=0" in c and "seed=1" not in c for c in evals)
    assert {c[c.index("policy=checkpoint") + 2] for c in evals if "policy=checkpoint" in c} == {
        "method=PPO seed1", "method=PPO-Lagrangian seed1"}  # the report pools "PPO" with "PPO seed1"
    [report] = [c for c in calls if c[0] == "python"]  # the variant's own pairs, not the untagged rows'
    assert "--compare=PPO-Lagrangian seed1=PPO seed1" in report and "--compare=PPO-Lagrangian=PPO" not in report


def test_rl_small_reports_a_second_seed_beside_the_first_pooled(tmp_path):
    """With TAG, the untagged runs of the same algos that OUT holds join the report: each variant is tested against
    its own algo's run, and with TAG=seed1 the untagged pair again, pooled over both seeds. The report runs for real on
    the records of docs/results (PPO and PPO-Lagrangian, training seeds 0 and 1, the same 200 val episodes)."""
    env = {**rl_small_stubs(tmp_path), "PYTHON": sys.executable}
    out = tmp_path / "rl"
    recorded_evals(out, ["rl_main/eval/ppo", "rl_lag_ddppo/eval/ppo_lag", "rl_seed1/eval/ppo_seed1",
                         "rl_seed1/eval/ppo_lag_seed1"])
    proc, _ = run_script("rl_small.sh", tmp_path, str(out), **env, TRAIN_SEED="1", TAG="seed1")
    assert proc.returncode == 0, proc.stderr
    text = (out / "report.md").read_text()
    for label in ("PPO", "PPO seed1", "PPO-Lagrangian", "PPO-Lagrangian seed1", "Goal follower"):
        assert f"| RVN (ours) | {label} |" in text, label
    # the variant against its own algo's run, the variant's pair, and the untagged pair, per seed and pooled
    assert "| PPO seed1 | PPO | 0.285 (57/200) | 0.185 (37/200) |" in text
    assert "| PPO-Lagrangian seed1 | PPO-Lagrangian |" in text and "| PPO-Lagrangian seed1 | PPO seed1 |" in text
    pooled = text[text.index("pooled over training seeds"):]
    assert "| PPO-Lagrangian | PPO | unlabelled + seed1 | 400 | 0.077 | 0.235 | 16–79, <1e-4 |" in pooled
    assert "1.04 [0.88, 1.22], 0.66 |" in pooled
    # one algo's second seed: the PPO runs in OUT are no algo of this run, so they stay out
    proc, _ = run_script("rl_small.sh", tmp_path, str(out), **env, ALGOS="ppo_lag", TRAIN_SEED="1", TAG="seed1")
    assert proc.returncode == 0, proc.stderr
    text = (out / "report.md").read_text()
    assert "| PPO-Lagrangian seed1 | PPO-Lagrangian |" in text and "| RVN (ours) | PPO-Lagrangian |" in text
    assert "| RVN (ours) | PPO |" not in text and "| RVN (ours) | PPO seed1 |" not in text
    # COMPARE naming a row OUT does not hold (another recipe's, not evaluated yet): listed as not tested, the rest reported
    proc, _ = run_script("rl_small.sh", tmp_path, str(out), **env, ALGOS="ppo_lag", TRAIN_SEED="1", TAG="seed1",
                         COMPARE="PPO-Lagrangian seed1=PPO 600k seed1")
    assert proc.returncode == 0, proc.stderr
    text = (out / "report.md").read_text()
    assert "Not tested (a row is not among these runs): PPO-Lagrangian seed1 = PPO 600k seed1." in text
    assert "| PPO-Lagrangian seed1 | PPO-Lagrangian |" in text



def test_rl_small_continues_runs_under_a_new_tag(tmp_path):
    """FROM=<tag> continues the runs of that tag (FROM=untagged: the untagged ones) in runs of TAG, each from its
    latest checkpoint (rvn-rl train.continue_from); the runs continued keep their folders. A FROM without a TAG of its
    own, or whose runs saved no checkpoint, is refused before any work."""
    env = {**rl_small_stubs(tmp_path), "ALGOS": "ppo ppo_lag", "TOTAL_STEPS": "128"}
    out = tmp_path / "rl"
    for bad, said in [({"FROM": "untagged"}, "FROM=untagged continues those runs in runs of another TAG"),
                      ({"FROM": "seed1", "TAG": "seed1"}, "FROM=seed1 continues those runs in runs of another TAG"),
                      ({"FROM": "a/b", "TAG": "x"}, "FROM='a/b'; use letters"),
                      ({"TAG": "untagged"}, "TAG=untagged names the untagged runs"),
                      ({"FROM": "untagged", "TAG": "x"}, f"FROM=untagged: {out}/train/ppo holds no checkpoint")]:
        proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, **bad)
        assert proc.returncode == 2 and said in proc.stderr and not calls, (bad, proc.stderr)
    for run in ("ppo", "ppo_lag"):
        (out / "train" / run / "checkpoints").mkdir(parents=True)
        (out / "train" / run / "checkpoints" / "latest").write_text("ckpt_000000000064\n")
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, FROM="untagged", TAG="128")
    assert proc.returncode == 0, proc.stderr
    trains = {c[1]: c for c in calls if c[0] == "rvn-rl"}
    for algo in ("ppo", "ppo_lag"):
        assert f"out_dir={out}/train/{algo}_128" in trains[f"algo={algo}"]
        assert trains[f"algo={algo}"][-1] == f"train.continue_from={out}/train/{algo}"
    evals = [c for c in calls if "policy=checkpoint" in c]
    assert {c[c.index("policy=checkpoint") + 2] for c in evals} == {"method=PPO 128", "method=PPO-Lagrangian 128"}
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, FROM="untagged", TAG="128")
    assert proc.returncode == 0 and not [c for c in calls if c[0] != "python"], proc.stderr  # all done: resumed


def test_rl_small_reports_a_continued_second_seed_pooled(tmp_path):
    """TRAIN_SEED=1 FROM=seed1 TAG=600k_seed1: the row "PPO 600k seed1" against the run it continued ("PPO seed1"),
    and the seed-0 pair ("PPO 600k" against "PPO") pooled over both seeds. The report runs for real on the records of
    docs/results (PPO at 400k and 600k env steps, training seeds 0 and 1): the pooled figures of
    2026-12-06_ppo_600k's report."""
    env = {**rl_small_stubs(tmp_path), "PYTHON": sys.executable, "ALGOS": "ppo"}
    out = tmp_path / "rl"
    recorded_evals(out, ["rl_main/eval/ppo", "rl_seed1/eval/ppo_seed1", "ppo_600k/eval/ppo_600k",
                         "ppo_600k/eval/ppo_600k_seed1"])
    (out / "train" / "ppo_seed1" / "checkpoints").mkdir(parents=True)
    (out / "train" / "ppo_seed1" / "checkpoints" / "latest").write_text("ckpt_000000400384\n")
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, TRAIN_SEED="1", FROM="seed1",
                             TAG="600k_seed1")
    assert proc.returncode == 0, proc.stderr
    [train] = [c for c in calls if c[0] == "rvn-rl"]
    assert f"out_dir={out}/train/ppo_600k_seed1" in train and "seed=1" in train
    assert train[-1] == f"train.continue_from={out}/train/ppo_seed1"
    text = (out / "report.md").read_text()
    for label in ("PPO", "PPO seed1", "PPO 600k", "PPO 600k seed1", "Goal follower"):
        assert f"| RVN (ours) | {label} |" in text, label
    assert "| PPO 600k seed1 | PPO seed1 | 0.230 (46/200) | 0.285 (57/200) |" in text
    pooled = text[text.index("pooled over training seeds"):]
    assert "| PPO 600k | PPO | unlabelled + seed1 | 400 | 0.225 | 0.235 | 41–45, 0.75 |" in pooled
    assert "0.66 [0.57, 0.78], <1e-4 |" in pooled


def test_rl_small_evaluates_each_run_at_its_last_checkpoints(tmp_path):
    """EVAL_CHECKPOINTS=k (SCALE=small: 2, tiny: 1): each run's row at its latest checkpoint, and its k-1 kept
    checkpoints before it as rows "<row> ckpt<env steps>" (rvn-eval +policy.env_steps) that join the report; above 2,
    rvn-rl keeps k checkpoints.
    A run keeping fewer is evaluated at those it keeps, and said so; a bad k, or a TAG named like such an evaluation,
    is refused before any work."""
    env = {**rl_small_stubs(tmp_path), "ALGOS": "ppo"}
    out = tmp_path / "rl"
    for bad, said in [({"EVAL_CHECKPOINTS": "0"}, "EVAL_CHECKPOINTS=0; give how many"),
                      ({"EVAL_CHECKPOINTS": "two"}, "EVAL_CHECKPOINTS=two; give how many"),
                      ({"TAG": "ckpt64"}, "TAG=ckpt64 ends like an evaluation of another checkpoint"),
                      ({"TAG": "more_ckpt64"}, "TAG=more_ckpt64 ends like")]:
        proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, **bad)
        assert proc.returncode == 2 and said in proc.stderr and not calls, (bad, proc.stderr)
    for steps in (64, 128, 192):
        (out / "train" / "ppo" / "checkpoints" / f"ckpt_{steps:012d}").mkdir(parents=True)
    (out / "eval" / "ppo_ckpt128").mkdir(parents=True)
    (out / "eval" / "ppo_ckpt128" / "metrics.json").write_text("{}")

    def evals(calls):
        return [(c[c.index("policy=checkpoint") + 2], c[-1]) for c in calls if "policy=checkpoint" in c]

    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, EVAL_CHECKPOINTS="3")
    assert proc.returncode == 0, proc.stderr
    [train] = [c for c in calls if c[0] == "rvn-rl"]
    assert train[-1] == "train.keep_checkpoints=3"
    assert evals(calls)[1:] == [("method=PPO ckpt128", "+policy.env_steps=128"),
                                ("method=PPO ckpt64", "+policy.env_steps=64")]
    assert evals(calls)[0][0] == "method=PPO" and "+policy.env_steps" not in evals(calls)[0][1]
    assert f"out_dir={out}/eval/ppo_ckpt64" in [c for c in calls if "method=PPO ckpt64" in c][0]
    [report] = [c for c in calls if c[0] == "python"]
    assert f"{out}/eval/ppo_ckpt128" in report and f"{out}/eval/ppo_ckpt64" not in report  # where it has its record
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, EVAL_CHECKPOINTS="2")
    assert proc.returncode == 0, proc.stderr
    assert "train.keep_checkpoints" not in " ".join(c for call in calls for c in call)  # rvn-rl's default keeps 2
    assert [m for m, _ in evals(calls)] == ["method=PPO", "method=PPO ckpt128"]
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **env, EVAL_CHECKPOINTS="5")
    assert proc.returncode == 0 and f"{out}/train/ppo keeps 3 checkpoints" in proc.stdout, proc.stdout
    assert [m for m, _ in evals(calls)] == ["method=PPO", "method=PPO ckpt128", "method=PPO ckpt64"]
    proc, calls = run_script("rl_small.sh", tmp_path, str(out), **{**env, "SCALE": "small"})  # its default: 2
    assert proc.returncode == 0 and [m for m, _ in evals(calls)] == ["method=PPO", "method=PPO ckpt128"], proc.stderr


def slurm_stubs(tmp_path: Path) -> None:
    """Stubs for the Slurm recipes: sbatch (fails the job named $FAIL_JOB, given as --job-name= or in the script on
    stdin), rvn-gen (a multirun exits with $MULTIRUN_STATUS; merge writes the train split the recipe reads), rvn-eval,
    and python (runs `python -c` for real)."""
    stub(tmp_path / "bin", "sbatch", 'script=$(cat)\n'
         'if [[ -n "${FAIL_JOB:-}" && " $* $script " == *"--job-name=$FAIL_JOB "* ]]; then exit 1; fi')
    stub(tmp_path / "bin", "rvn-gen", 'if [[ "$1" == -m ]]; then exit "${MULTIRUN_STATUS:-0}"; fi\n'
         'for a; do case $a in out_dir=*) o=${a#out_dir=} ;; dataset=*) d=${a#dataset=} ;; esac; done\n'
         'mkdir -p "$o/data_splits/rvn_$d/train" && echo rvn_${d}_0 >"$o/data_splits/rvn_$d/train/traj_names.txt"')
    stub(tmp_path / "bin", "rvn-eval")
    stub(tmp_path / "bin", "python", f'if [[ "$1" == -c ]]; then exec {shlex.quote(sys.executable)} "$@"; fi')


def test_a_failed_training_job_stops_the_slurm_recipes(tmp_path):
    """`sbatch --wait ... &` then a bare `wait` returned 0 whatever the jobs did: the recipes went on to evaluate
    models that never finished training. Now each job is waited for and a failed one ends the recipe, naming it."""
    slurm_stubs(tmp_path)
    proc, calls = run_script("rl_paper_scale.sh", tmp_path, DEPTH_SOURCE="true", FAIL_JOB="rvn-rl-ddppo")
    assert proc.returncode == 1, proc.stderr
    assert "rl_paper_scale.sh: error: training job(s) failed: rvn-rl-ddppo (" in proc.stderr
    assert [c[0] for c in calls] == ["sbatch"] * 4  # every job waited for, nothing evaluated
    proc, calls = run_script("experiment_slurm.sh", tmp_path, FAIL_JOB="rvn-train-nomad_neg")
    assert proc.returncode == 1, proc.stderr
    assert (f"experiment_slurm.sh: error: training job(s) failed: rvn-train-nomad_neg "
            f"({tmp_path / 'out' / 'train' / 'nomad_neg.slurm.log'})") in proc.stderr
    assert [c[0] for c in calls if c[0] != "rvn-gen" and c[1:2] != ["-c"]] == ["sbatch"] * 3
    proc, calls = run_script("rl_paper_scale.sh", tmp_path, DEPTH_SOURCE="true")  # all trained: evaluated, reported
    assert proc.returncode == 0, proc.stderr
    assert [c[0] for c in calls] == ["sbatch"] * 4 + ["rvn-eval"] * 8 + ["python"]


def test_rl_paper_scale_evaluates_on_the_cluster(tmp_path):
    """rl_paper_scale.sh ran every rvn-eval row (50 scenes x 20 episodes, 8 of them) on the submit host; they are
    Slurm array tasks now, as experiment_slurm.sh's, and their overrides compose."""
    proc = subprocess.run(["bash", str(REPO / "jobs" / "rl_paper_scale.sh")], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "DRY_RUN": "1", "OUT": str(tmp_path / "out"), "DEPTH_SOURCE": "true",
                               "PARTITION": "gpu"})
    assert proc.returncode == 0, proc.stderr
    evals = [shlex.split(ln[2:]) for ln in proc.stdout.splitlines() if ln.startswith("+ rvn-eval")]
    assert len(evals) == 8
    for c in evals:
        assert c[1:4] == ["-m", "hydra/launcher=slurm", "hydra.launcher.partition=gpu"], c
        assert "episodes.first_scene=range(0,50,5)" in c and "out_dir=" + str(tmp_path / "out" / "eval") in " ".join(c)
    args = [a.replace("range(0,50,5)", "0") for a in evals[-1][1:] if a != "-m" and not a.startswith("hydra")]
    composed = subprocess.run([sys.executable, "-m", MODULES["rvn-eval"], *args, "--cfg", "job", "--resolve"],
                              capture_output=True, text=True, timeout=120)
    assert composed.returncode == 0, composed.stderr[-2000:]
    assert f"out_dir: {tmp_path / 'out' / 'eval' / 'test' / 'ddppo_depth' / 'scenes_0'}" in composed.stdout


def test_experiment_slurm_keeps_expert_trajectories_for_nomad_e(tmp_path):
    """TRAJ=1 makes NEG 1 (at least one negative a scene): KEEP = TRAJ - NEG was 0 and NoMaD_e's split file came out
    empty; as in small_experiment.sh, every expert trajectory is kept when the negatives would leave none."""
    slurm_stubs(tmp_path)
    for traj, kept in (("1", ["rvn_expert_0"]), ("400", ["rvn_expert_0"])):
        proc, _ = run_script("experiment_slurm.sh", tmp_path, TRAJ=traj)
        assert proc.returncode == 0, proc.stderr
        split = tmp_path / "out" / "splits_neg" / "rvn_expert" / "train" / "traj_names.txt"
        assert split.read_text().split() == kept, traj


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


def test_rl_small_stops_the_other_training_when_one_fails(tmp_path):
    """PPO and PPO-Lagrangian train side by side; when PPO failed, the recipe exited and PPO-Lagrangian's rvn-rl
    kept running (for up to two hours at SCALE=small, on the cores a rerun would use). It is stopped now."""
    import time

    env = rl_small_stubs(tmp_path)
    slow = tmp_path / "slow.pid"
    proc, _ = run_script("rl_small.sh", tmp_path, str(tmp_path / "rl"), **env, FAIL_ALGO="algo=ppo",
                         SLOW_ALGO="algo=ppo_lag", SLOW_PID=str(slow))
    pid = int(slow.read_text())
    try:
        assert proc.returncode == 1 and "rl_small: a training failed" in proc.stderr, proc.stderr
        deadline = time.monotonic() + 10
        while alive(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not alive(pid), "PPO-Lagrangian's rvn-rl still runs"
    finally:
        if alive(pid):
            os.kill(pid, 9)


def test_merge_runs_after_a_failed_multirun(tmp_path):
    """A failed shard made `rvn-gen -m` exit 1 and set -e stopped the recipes before `mode=merge`, which the comments
    said lists the missing scenes. The merges run now, then the recipe stops with the multirun's status."""
    stub(tmp_path / "bin", "rvn-gen", compose_only("rvn-gen"))
    proc, calls = run_script("gen_paper_scale.sh", tmp_path, MULTIRUN_STATUS="1")
    assert proc.returncode == 1, proc.stderr
    assert [c[1] for c in calls] == ["-m", "mode=merge"] and "dataset=expert" in calls[1]  # no negatives on a failure
    assert "gen_paper_scale.sh: error: the expert dataset is incomplete (rvn-gen -m exit 1, merge exit 0;" in proc.stderr
    slurm_stubs(tmp_path)
    proc, calls = run_script("experiment_slurm.sh", tmp_path, MULTIRUN_STATUS="1")
    assert proc.returncode == 1, proc.stderr
    assert [c[1] for c in calls if c[0] == "rvn-gen"] == ["-m", "-m", "mode=merge", "mode=merge"]
    assert not [c for c in calls if c[0] in ("sbatch", "rvn-eval")]  # nothing trained on incomplete data
    assert "experiment_slurm.sh: error: the datasets are incomplete" in proc.stderr


def calls_by_folder(calls: list[list[str]], tool: str) -> dict[str, list[str]]:
    """The stub ``tool``'s calls by the last folder of their ``out_dir=``."""
    return {next(a for a in c if a.startswith("out_dir=")).rsplit("/", 1)[1]: c for c in calls if c[0] == tool}


def test_small_experiment_runs_each_seeds_rows_after_the_seed_before(tmp_path):
    """jobs/small_experiment.sh with SEEDS="0 1" and every optional row (tests/test_experiment_smoke.py runs the real
    tools for one seed): seed 1's trainings and rows follow seed 0's complete block, with the suffix _seed1 on its
    folders and steps and " seed1" on its labels, NoMaD-Neg seed 1 adopts seed 1's NoMaD-PointGoal (at its earlier
    checkpoint too), and the report gets both seeds' rows and pairs (tests/test_report.py pools them over seeds)."""
    real_python = sys.executable
    out_dir = 'for a in "$@"; do [[ "$a" == out_dir=* ]] && out=${a#out_dir=}; done\n'  # the call's out_dir= as $out
    stub(tmp_path / "bin", "rvn-gen", out_dir + 'mkdir -p "$out/data_splits/${out##*/}/train"\n'
                                      'printf "proc_train_0000_expert_0000\\nproc_train_0000_expert_0001\\n" '
                                      '>"$out/data_splits/${out##*/}/train/traj_names.txt"')
    stub(tmp_path / "bin", "rvn-train", out_dir + 'mkdir -p "$out/model/ckpt_00000001" "$out/model/ckpt_00000002"')
    stub(tmp_path / "bin", "rvn-eval")
    stub(tmp_path / "bin", "python", f'[[ "$1" == -c ]] && exec {shlex.quote(real_python)} "$@"\nexit 0')
    out = tmp_path / "exp"
    proc, calls = run_script("small_experiment.sh", tmp_path, str(out), SCALE="tiny", PYTHON="python", NEG_ARGMIN="1",
                             SEEDS="0 1", DEPTH_AUX="0.5", DEPTH_VETO="0.5", TURN_COMMIT="1", EVAL_CHECKPOINTS="2",
                             CKPT_EVERY="1")
    assert proc.returncode == 0, proc.stderr[-3000:]
    steps = [ln.split("\t")[0] for ln in (out / "timings.tsv").read_text().splitlines()]
    per_seed = ["train_nomad", "train_nomad_neg", "eval_nomad", "eval_nomad_vote", "eval_nomad_neg", "eval_nomad_ckpt1",
                "train_nomad_neg_ckpt1", "eval_nomad_neg_ckpt1", "eval_nomad_vote_veto", "eval_nomad_neg_veto",
                "eval_nomad_neg_veto_commit", "eval_nomad_neg_argmin"]
    seed1 = [s.replace("_ckpt1", "_seed1_ckpt1") if "ckpt1" in s else s + "_seed1" for s in per_seed]
    assert steps == ["gen_expert", "gen_negative", "gen_val", "train_vint", "eval_random", "eval_oracle",
                     "eval_goal_follower", "eval_trajectory_oracle", "eval_vint", *per_seed, *seed1]
    exp = str(out.resolve())
    trains = calls_by_folder(calls, "rvn-train")
    assert "seed=1" in trains["nomad_pointgoal_seed1"] and "seed=0" in trains["nomad_pointgoal"]
    for name in ("nomad_neg_seed1", "nomad_neg_seed1_ckpt1"):
        assert f"train.expert_from={exp}/train/nomad_pointgoal_seed1" in trains[name] and "seed=1" in trains[name]
    assert "train.expert_step=1" in trains["nomad_neg_seed1_ckpt1"]
    evals = calls_by_folder(calls, "rvn-eval")
    for method, name in (("NoMaD-PointGoal", "nomad_pointgoal"), ("NoMaD-PointGoal-vote", "nomad_pointgoal_vote"),
                         ("NoMaD-Neg", "nomad_neg"), ("NoMaD-PointGoal-vote-veto", "nomad_pointgoal_vote_veto"),
                         ("NoMaD-Neg-veto", "nomad_neg_veto"), ("NoMaD-Neg-veto-commit", "nomad_neg_veto_commit"),
                         ("NoMaD-Neg-argmin", "nomad_neg_argmin")):
        assert f"method={method} seed1" in evals[f"{name}_seed1"] and f"method={method}" in evals[name]
        source = "nomad_neg" if name.startswith("nomad_neg") else "nomad_pointgoal"
        assert f"policy.checkpoint_path={exp}/train/{source}_seed1" in evals[f"{name}_seed1"]
    early = evals["nomad_pointgoal_seed1_ckpt1"]
    assert "method=NoMaD-PointGoal seed1 ckpt1" in early and "+policy.step=1" in early
    assert f"policy.checkpoint_path={exp}/train/nomad_neg_seed1_ckpt1" in evals["nomad_neg_seed1_ckpt1"]
    report = next(c for c in calls if c[0] == "python" and "rvn_data.benchmark.report" in c)
    rows = ["random", "oracle", "goal_follower", "trajectory_oracle", "vint_pointgoal"]
    for sfx in ("", "_seed1"):
        rows += [f"nomad_pointgoal{sfx}", f"nomad_pointgoal_vote{sfx}", f"nomad_neg{sfx}", f"nomad_pointgoal{sfx}_ckpt1",
                 f"nomad_neg{sfx}_ckpt1", f"nomad_pointgoal_vote_veto{sfx}", f"nomad_neg_veto{sfx}",
                 f"nomad_neg_veto_commit{sfx}", f"nomad_neg_argmin{sfx}"]
    assert [a for a in report if a.startswith(exp + "/eval/")] == [f"{exp}/eval/{n}" for n in rows]
    for pair in ("NoMaD-Neg seed1=NoMaD-PointGoal seed1", "NoMaD-Neg seed1 ckpt1=NoMaD-PointGoal seed1 ckpt1",
                 "NoMaD-Neg-veto-commit seed1=NoMaD-Neg-veto seed1", "NoMaD-Neg-argmin seed1=NoMaD-Neg seed1",
                 "NoMaD-PointGoal seed1=Goal follower", "NoMaD-Neg=NoMaD-PointGoal"):
        assert f"--compare={pair}" in report, pair
