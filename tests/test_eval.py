"""rvn-eval end to end on a small val set: oracle / random figures, workers, resume, errors, tables."""
import json
import os
import subprocess
import sys

import pytest
from conftest import without_shared_cache

from rvn_data.benchmark.metrics import compute_metrics, read_records
from rvn_data.benchmark.table import main as table_main
from rvn_data.benchmark.table import render_table

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

SMALL = ["split=val", "episodes.num_scenes=2", "episodes.per_scene=2", "episodes.n_goals=3",
         "camera.width=32", "camera.height=32", "progress=false"]


def rvn_eval(tmp_path, *overrides, env=None):
    cmd = [sys.executable, "-c", "from rvn_data.benchmark.cli import main; main()", *SMALL,
           f"episodes.dir={tmp_path / 'episodes'}", *overrides]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env, cwd=tmp_path)


def ok(proc):
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


def load(out):
    return json.loads((out / "metrics.json").read_text())


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One oracle run with 1 worker and one with 2, sharing an episode cache; the second reads the navmeshes
    the first built (its cache root)."""
    tmp = tmp_path_factory.mktemp("eval")
    ok(rvn_eval(tmp, "policy=oracle", f"out_dir={tmp / 'oracle1'}", "workers=1",
                env=without_shared_cache(os.environ)))  # its default cache root, <out_dir>/cache
    ok(rvn_eval(tmp, "policy=oracle", f"out_dir={tmp / 'oracle2'}", "workers=2", f"cache_dir={tmp / 'oracle1' / 'cache'}"))
    return tmp


def test_oracle_figures_and_files(runs):
    out = runs / "oracle1"
    m = load(out)
    assert m["split"] == "val" and m["policy"] == "oracle" and m["episodes"] == 4
    assert m["SR_1"] >= 0.95 and m["CPK"] is not None and m["CPK"] <= 1.0
    assert m["E_G"] > 2.5 and 0.5 < m["SPL_1"] <= 1.0
    recomputed = compute_metrics(read_records(out / "episodes.jsonl"))
    assert {k: m[k] for k in recomputed} == recomputed
    table = (out / "table.md").read_text()
    assert "| RVN (ours) | oracle |  |  |  | 1.000 |" in table and "NoMaD-Neg" in table
    (index_path,) = (runs / "episodes" / "procedural").glob("val-*/index.json")  # one folder per settings
    index = json.loads(index_path.read_text())
    assert [s["episodes"] for s in index["scenes"]] == [2, 2]


def test_workers_do_not_change_results(runs):
    assert len(list((runs / "oracle1" / "cache" / "navmesh").glob("*.npz"))) == 2  # a built navmesh per scene
    assert not (runs / "oracle2" / "cache").exists()  # read from oracle1's cache root: the same episodes
    for name in ("episodes.jsonl", "metrics.json"):
        assert (runs / "oracle1" / name).read_bytes() == (runs / "oracle2" / name).read_bytes()
    # each scene's renderer line, logged where the episodes ran: in rvn-eval's process with workers=1, in the worker
    # processes with workers=2, whose records reached neither the console nor the run's log file before
    for run in ("oracle1", "oracle2"):
        log = (runs / run / "rvn-eval.log").read_text()
        assert all(f"[INFO] - renderer for procedural:val/{i}: " in log for i in (0, 1)), (run, log)


def test_random_policy(runs):
    out = runs / "random"
    ok(rvn_eval(runs, "policy=random", f"out_dir={out}"))
    m = load(out)
    assert m["SR_1"] <= 0.05 and m["policy"] == "random" and m["CPK"] > 1.0


def test_resume_skips_done_episodes(runs, tmp_path):
    src, out = runs / "oracle1", tmp_path / "resumed"
    out.mkdir()
    (out / "run.json").write_bytes((src / "run.json").read_bytes())
    lines = (src / "episodes.jsonl").read_text().splitlines()
    first = json.loads(lines[0])
    first["steps"] += 1000  # marks a record the resumed run must keep, not recompute
    torn = lines[2][: len(lines[2]) // 2]  # an append cut short by the interruption
    (out / "episodes.jsonl").write_text(json.dumps(first) + "\n" + lines[1] + "\n" + torn)
    ok(rvn_eval(runs, "policy=oracle", f"out_dir={out}"))
    got = read_records(out / "episodes.jsonl")
    assert got[0]["steps"] == json.loads(lines[0])["steps"] + 1000
    assert got[1:] == [json.loads(x) for x in lines[1:]]
    assert load(out)["steps"] == load(src)["steps"] + 1000
    # a rerun of a finished run, with workers: nothing left to do, the same files
    before = {n: (out / n).read_bytes() for n in ("episodes.jsonl", "metrics.json")}
    ok(rvn_eval(runs, "policy=oracle", f"out_dir={out}", "workers=2"))
    assert {n: (out / n).read_bytes() for n in before} == before


def test_resume_with_other_settings_is_an_error(runs):
    proc = rvn_eval(runs, "policy=random", f"out_dir={runs / 'oracle1'}")
    assert proc.returncode != 0
    assert "run.json was made with method='oracle'" in proc.stderr and "Traceback" not in proc.stderr


def test_invalid_action_names_policy(runs, tmp_path):
    (tmp_path / "badpol.py").write_text(
        "class BadPolicy:\n    def __init__(self, **kw):\n        pass\n    def reset(self):\n        pass\n"
        "    def act(self, obs):\n        return 7\n")
    env = dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    proc = rvn_eval(runs, "policy=random", "policy._target_=badpol.BadPolicy",
                    "method=Bad", f"out_dir={tmp_path / 'bad'}", env=env)
    assert proc.returncode != 0
    assert "policy 'Bad' returned invalid action 7" in proc.stderr and "Traceback" not in proc.stderr
    # no package registers it (entry points rvn.policies): imported by its dotted path, with a note saying so
    assert "rvn-eval: note: policy._target_=badpol.BadPolicy is not a registered policy" in proc.stderr


def test_one_process_runs_the_policy_it_checked(runs, tmp_path):
    """rvn-eval builds the policy once to check it before any episode; with workers=1, or one episode to run, that
    policy runs the episodes (bound to the env), where each worker process builds its own."""
    (tmp_path / "countpol.py").write_text(
        "import os\n"
        "class CountPolicy:\n"
        "    def __init__(self, **kw):\n        self.log('built')\n"
        "    def log(self, what):\n"
        "        with open(os.environ['COUNT_LOG'], 'a') as f:\n            f.write(f'{what} {os.getpid()}\\n')\n"
        "    def bind(self, env):\n        self.log('bound')\n"
        "    def reset(self):\n        pass\n"
        "    def act(self, obs):\n        return 1\n")
    for workers in (1, 2):
        log = tmp_path / f"count{workers}.txt"
        env = dict(os.environ, COUNT_LOG=str(log),
                   PYTHONPATH=f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
        ok(rvn_eval(runs, "policy=random", "policy._target_=countpol.CountPolicy", "method=Count", f"workers={workers}",
                    f"out_dir={tmp_path / f'count{workers}'}", env=env))
        whats, pids = zip(*(ln.split() for ln in log.read_text().splitlines()))
        if workers == 1:  # built, checked, then bound and run in the same process
            assert whats == ("built", "bound") and pids[0] == pids[1]
        else:  # the check's policy, then one built and bound in each worker process
            assert whats.count("built") == 3 and whats.count("bound") == 2
        assert load(tmp_path / f"count{workers}")["episodes"] == 4
    assert load(tmp_path / "count1")["SR_1"] == load(tmp_path / "count2")["SR_1"]
    log = tmp_path / "count_one.txt"  # workers=2 with one episode: no pool of one
    env = dict(os.environ, COUNT_LOG=str(log), PYTHONPATH=f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    ok(rvn_eval(runs, "policy=random", "policy._target_=countpol.CountPolicy", "method=Count", "workers=2",
                "episodes.num_scenes=1", "episodes.per_scene=1", f"out_dir={tmp_path / 'count_one'}", env=env))
    whats, pids = zip(*(ln.split() for ln in log.read_text().splitlines()))
    assert whats == ("built", "bound") and pids[0] == pids[1] and load(tmp_path / "count_one")["episodes"] == 1


def test_missing_scene_is_named(runs, tmp_path):
    missing = tmp_path / "no_such_scenes"
    proc = rvn_eval(runs, "scenes=mesh_dir", f"scenes.root={missing}", f"out_dir={tmp_path / 'x'}")
    assert proc.returncode != 0 and str(missing) in proc.stderr and "Traceback" not in proc.stderr


def test_a_mesh_folder_without_split_folders_is_said_and_reported(tmp_path):
    """scenes=mesh_dir on a folder without split folders evaluates on every mesh there, which every other split takes
    too (the training data's): rvn-eval says so, metrics.json records it and the report warns above the table."""
    import trimesh

    from rvn_data.benchmark.runs import find_runs, provenance_note
    from rvn_data.scenes.loader import load_scene

    scans = tmp_path / "scans"
    scans.mkdir()
    trimesh.Trimesh(*load_scene("procedural:val/0").triangles(), process=False).export(scans / "apartment.glb")
    out = tmp_path / "random"
    proc = ok(rvn_eval(tmp_path, "policy=random", "scenes=mesh_dir", f"scenes.root={scans}", f"out_dir={out}",
                       "episodes.per_scene=1"))
    assert f"scenes.root={scans} has no val/ folder, so split=val takes every mesh in it, as split train and test " \
           "do: their scenes are the same" in proc.stderr
    assert load(out)["shared_scenes"] == {"folder": str(scans), "splits": ["train", "test"]}
    assert load(out)["episodes"] == 1
    assert "evaluated on scenes that other splits share (a mesh folder without a folder per split, so a model may " \
           f"have trained on them): random ({scans}, also train and test)" in provenance_note(find_runs([out]))


def test_table_merges_metrics(tmp_path, capsys):
    base = {"SR_1": 0.5, "E_G": 1.25, "CPK": 12.34, "SPL_1": 0.4, "episodes": 4, "policy": "checkpoint",
            "method": "NoMaD-Neg (ours)"}
    (tmp_path / "a.json").write_text(json.dumps({**base, "split": "val"}))
    (tmp_path / "b.json").write_text(json.dumps({**base, "split": "test", "SR_1": 0.25, "CPK": None}))
    assert table_main([str(tmp_path / "a.json"), str(tmp_path / "b.json"), "-o", str(tmp_path / "t.md")]) == 0
    table = (tmp_path / "t.md").read_text()
    assert "| RVN (ours) | NoMaD-Neg (ours) |  |  |  | 0.500 | 1.25 | 12.3 | 0.250 | 1.25 | – |" in table
    assert "| RL (paper) | DD-PPO | 0.899 | 13.28 | 9.2 | 0.865 | 11.86 | 10.5 | 0.886 | 13.90 | 8.7 |" in table
    assert "paper" not in render_table([{**base, "split": "val"}], reference=False)
    assert table_main([str(tmp_path / "missing.json")]) == 2
    assert "missing.json" in capsys.readouterr().err


def test_bad_checkpoint_is_one_line_error(runs, tmp_path):
    ckpt = tmp_path / "not_a_checkpoint"
    ckpt.mkdir()
    proc = rvn_eval(runs, "policy=checkpoint", f"policy.checkpoint_path={ckpt}", f"out_dir={tmp_path / 'y'}")
    assert proc.returncode == 2 and not (tmp_path / "y").exists()
    assert "policy 'not_a_checkpoint'" in proc.stderr and str(ckpt) in proc.stderr and "rvn-train" in proc.stderr
    assert "Traceback" not in proc.stderr and "Error executing job" not in proc.stderr


def test_trajectory_oracle_measures_the_action_adapter(runs, tmp_path):
    """policy=trajectory_oracle: the expert's own next poses through the IL adapter. The default
    rule (first waypoint beyond d_step/2) reproduces the expert and reaches goals; steering to
    the last of 8 waypoints cuts corners into walls."""
    first = runs / "traj_first"
    ok(rvn_eval(runs, "policy=trajectory_oracle", f"out_dir={first}", "method=Trajectory oracle"))
    last = runs / "traj_last"
    ok(rvn_eval(runs, "policy=trajectory_oracle", "policy.waypoint_index=-1", f"out_dir={last}"))
    m_first, m_last = load(first), load(last)
    assert m_first["episodes"] == m_last["episodes"] == 4
    assert m_first["SR_1"] >= 0.5 and m_first["E_G"] >= 1.5, m_first  # 0.5 / 1.5 of 3 goals here; 0.80 / 4.1 of 32 on 60 val episodes
    assert m_last["E_G"] < m_first["E_G"], (m_first, m_last)


def test_goal_follower_drives_straight_at_the_goal(runs):
    """policy=goal_follower (blind baseline): turns toward the point goal, drives at it, stops
    inside the success radius; in apartments a wall soon stands in the way."""
    from rvn_data.conventions import Action
    from rvn_data.benchmark.policies import GoalFollowerPolicy

    pol = GoalFollowerPolicy()
    assert pol.act({"pointgoal": [3.0, 0.2]}) == Action.MOVE_FORWARD
    assert pol.act({"pointgoal": [1.0, 1.0]}) == Action.TURN_LEFT
    assert pol.act({"pointgoal": [-1.0, -0.1]}) == Action.TURN_RIGHT
    assert pol.act({"pointgoal": [0.2, 0.1]}) == Action.STOP
    out = runs / "goal_follower"
    ok(rvn_eval(runs, "policy=goal_follower", f"out_dir={out}", "method=Goal follower"))
    records = read_records(out / "episodes.jsonl")
    assert len(records) == 4 and load(out)["method"] == "Goal follower"
    for r in records:  # it moves (at least one 0.25 m forward step, not turning on the spot) and ends at a wall or a goal
        assert r["path_length"] > 0.2 and (r["termination"] == "collision" or r["goals_reached"] > 0), r
