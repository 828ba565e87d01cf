"""The benchmark scripts themselves: benchmarks/README.md lists every one and names none that is gone (the README's
pointer to the benchmarks is that list, so a script added or renamed without it would be one nobody finds), and
decision.py's breakdown of a NoMaD decision measures the parts the policy runs."""
from __future__ import annotations

import re
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def test_benchmarks_readme_lists_every_script():
    text = (BENCHMARKS / "README.md").read_text()
    named = set(re.findall(r"`([\w.]+\.(?:py|sh|mjs))`", text))
    scripts = {p.name for p in BENCHMARKS.iterdir() if p.suffix in (".py", ".sh", ".mjs")}
    assert scripts - named == set(), f"benchmarks/README.md does not list {sorted(scripts - named)}"
    assert named - scripts == set(), f"benchmarks/README.md names {sorted(named - scripts)}, which are not in benchmarks/"


def test_decision_parts_of_a_nomad_decision(monkeypatch):
    """One frame through the encoder, the condition with the FiLM biases, and the model's denoising steps: each part
    timed, and the profiled steps' matrix products a share of their operator time with a rate from their FLOPs."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import decision

    from rvn_il.models import load_model_config

    parts = decision.decision_parts("small", reps=2)
    assert set(parts) == {"encoder", "condition", "denoise", "matmul_share", "matmul_gflops", "steps"}
    assert parts["steps"] == load_model_config("nomad_pointgoal", "small")["num_diffusion_iters"]
    assert all(parts[k] > 0 for k in ("encoder", "condition", "denoise", "matmul_gflops"))
    assert 0 < parts["matmul_share"] < 1


def test_pool_fallback_counts_draws_with_no_pool_goal_in_range(monkeypatch, capsys):
    """benchmarks/pool_fallback.py at a tiny size: a pool of one goal has no other goal in range of itself (a reached
    goal's next draw always falls back: 1/1), a pool of 16 on the same scene leaves fewer starts without one; each
    line names the counts and a fallback's ms; --scene gives the scenes by spec (a mesh file, or as here the first
    procedural train scene)."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import pool_fallback

    counts = []
    for goals, scenes in ((1, ["--scenes", "1"]), (16, ["--scene", "procedural:train/0"])):
        pool_fallback.main([*scenes, "--goals", str(goals), "--starts", "12"])
        out = capsys.readouterr().out
        assert out.startswith("1 procedural train scenes" if goals == 1 else "1 scene(s) given"), out
        m = re.search(r"at a pool goal \(a reached goal's next draw\) (\d+)/(\d+) .*at a random start \(a reset's draw\) "
                      r"(\d+)/12 ", out)
        assert m and re.search(r"a fallback .*: median [\d.]+ ms, slowest [\d.]+ ms over 1 scenes", out), out
        counts.append(tuple(int(x) for x in m.groups()))
    assert counts[0][:2] == (1, 1) and counts[1][1] == 16
    assert counts[1][2] <= counts[0][2]


def test_env_state_times_state_steps_and_resets(monkeypatch, capsys):
    """benchmarks/env_state.py at a tiny size: the microseconds of a state step and of a reset, and the episodes'
    return, the same in two runs (the figure a change that should not change the episodes keeps)."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import env_state

    returns = []
    for _ in range(2):
        env_state.main(["--steps", "300", "--rounds", "2", "--goal-pool", "8"])
        out = capsys.readouterr().out
        m = re.search(r"([\d.]+) us a step \(median of 2 rounds of 300; [\d.]+-[\d.]+\), a reset (\d+) us; "
                      r"episodes' return (-?[\d.]+)", out)
        assert m and float(m.group(1)) > 0 and int(m.group(2)) > 0, out
        returns.append(m.group(3))
    assert returns[0] == returns[1]


def test_scene_checks_prints_the_checks_share_of_a_load(monkeypatch, capsys, tmp_path):
    """benchmarks/scene_checks.py on a procedural apartment written as a PLY and a mesh given by path (a 3 m room):
    a row each with its triangles, the load's ms, the checks' ms and their share."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import scene_checks
    import trimesh

    trimesh.creation.box(extents=[3.0, 2.5, 3.0]).export(tmp_path / "room.ply")
    scene_checks.main(["--procedural", "1", "--repeats", "1", "--mesh", str(tmp_path / "room.ply")])
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["mesh", "triangles", "load", "ms", "checks", "ms", "share"]
    assert [ln.split()[0] for ln in lines[1:]] == ["room", "procedural_train_0"]
    for ln in lines[1:]:
        m = re.fullmatch(r"\S+ +[\d,]+ +([\d.]+) +([\d.]+) +(\d+)%", ln)
        assert m and float(m.group(1)) > 0 and float(m.group(2)) > 0, ln
