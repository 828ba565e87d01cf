"""jobs/real_sim_experiment.sh end to end at SCALE=tiny (issue 34's stand-in for the paper's Real+Sim): the "real"
dataset with its own camera and step, three trainings (sim, real, the mixture through data.datasets), each model on
both robots with the mismatch recorded, the report with its paired comparisons; a rerun skips every step."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
import yaml
from conftest import run_recipe


def recipe(out: Path, **env) -> subprocess.CompletedProcess:
    return run_recipe("real_sim_experiment.sh", out, **env)


@pytest.mark.slow
def test_real_sim_recipe_end_to_end(tmp_path):
    out = tmp_path / "rs"
    proc = recipe(out)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    real = yaml.safe_load((out / "train" / "real" / "config.yaml").read_text())["embodiment"]
    assert (real["camera"]["hfov_deg"], real["camera"]["h_camera"], real["agent"]["d_step"]) == (120.0, 0.3, 0.2)
    mix = out / "train" / "mix" / "model"
    stats = json.loads((mix / (mix / "latest").read_text().strip() / "stats.json").read_text())
    assert [round(d["step_m"], 3) for d in stats["datasets"]] == [0.25, 0.2] and stats["metric_waypoint_spacing"] == 0.25
    assert [d["share"] for d in stats["datasets"]] == [0.5, 0.5]
    crossed = json.loads((out / "eval" / "sim_real" / "metrics.json").read_text())["embodiment_mismatch"]
    assert {d["setting"] for d in crossed} == {"agent.d_step", "camera.hfov_deg", "camera.h_camera"}
    assert "embodiment_mismatch" not in json.loads((out / "eval" / "real_real" / "metrics.json").read_text())
    report = (out / "report.md").read_text()
    for model in ("sim", "real", "mix"):
        for robot in ("sim", "real"):
            assert f"| NoMaD-PointGoal {model}-data @{robot} | Val |" in report
    for robot in ("sim", "real"):  # the reference rows beside them
        for row in ("Trajectory oracle", "Goal follower", "Random"):
            assert f"| {row} @{robot} | Val |" in report
    assert "| NoMaD-PointGoal mix-data @real | NoMaD-PointGoal sim-data @real |" in report
    assert "Evaluated on another robot or camera than they were trained for: NoMaD-PointGoal real-data @sim" in report
    again = recipe(out)
    assert again.returncode == 0 and again.stdout.count("done before, skipped") == 17, again.stdout[-2000:]
    bad = recipe(tmp_path / "bad", SIM_WEIGHT="1.5")
    assert bad.returncode == 2 and "SIM_WEIGHT=1.5" in bad.stderr and not (tmp_path / "bad").exists()
