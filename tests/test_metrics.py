"""Benchmark metrics from hand-written per-episode records."""
import json
import math
import os

import pytest

from rvn_data.benchmark.metrics import (EpisodeTracker, compute_metrics, metrics_from_jsonl, read_records, spl,
                              write_records)


def goal(d0, reached, steps, length, collisions=0):
    return {"d0": d0, "reached": reached, "steps": steps, "path_length": length, "collisions": collisions}


def record(i, goals, termination, collisions=0):
    reached = sum(g["reached"] for g in goals)
    return {
        "scene_id": "procedural:val/0", "scene_index": 0, "episode_index": i, "episode_id": f"procedural:val/0#{i}",
        "goals_reached": reached, "first_goal_success": bool(goals and goals[0]["reached"]),
        "path_length": sum(g["path_length"] for g in goals), "collisions": collisions,
        "steps": sum(g["steps"] for g in goals), "d0": goals[0]["d0"] if goals else None,
        "termination": termination, "goals": goals,
    }


RECORDS = [
    # 2 goals reached, then a collision after 1 m more: 10 m in all, 1 collision
    record(0, [goal(5.0, True, 30, 5.0), goal(4.0, True, 20, 4.0), goal(6.0, False, 5, 1.0, 1)], "collision", 1),
    # first goal reached on a detour (L = 8 > d0 = 4), then timeout
    record(1, [goal(4.0, True, 40, 8.0), goal(7.0, False, 500, 2.0)], "timeout"),
    # nothing reached: collision after 0.5 m
    record(2, [goal(6.0, False, 3, 0.5, 1)], "collision", 1),
    # stood still until timeout
    record(3, [goal(5.0, False, 500, 0.0)], "timeout"),
]


def test_metrics_by_hand():
    m = compute_metrics(RECORDS)
    assert m["episodes"] == 4
    assert m["SR_1"] == pytest.approx(2 / 4)
    assert m["E_G"] == pytest.approx((2 + 1 + 0 + 0) / 4)
    # 2 collisions over 10 + 10 + 0.5 + 0 m = 20.5 m
    assert m["CPK"] == pytest.approx(2 / 0.0205)
    assert m["SPL_1"] == pytest.approx((1.0 + 4.0 / 8.0 + 0 + 0) / 4)
    assert m["path_length"] == pytest.approx(20.5 / 4)
    assert m["collisions"] == 2 and m["success_all_goals"] == 0


def test_spl_definition():
    assert spl(True, 5.0, 5.0) == 1.0
    assert spl(True, 5.0, 10.0) == 0.5
    assert spl(True, 5.0, 4.0) == 1.0  # max(d0, L)
    assert spl(False, 5.0, 5.0) == 0.0


def test_cpk_edge_cases():
    still = record(0, [goal(5.0, False, 500, 0.0)], "timeout")
    assert compute_metrics([still])["CPK"] == 0.0
    bumped = record(1, [goal(5.0, False, 1, 0.0, 1)], "collision", 1)
    assert compute_metrics([bumped])["CPK"] is None  # a collision without travel has no rate
    with pytest.raises(ValueError, match="no episode records"):
        compute_metrics([])


def test_bad_record_named():
    bad = dict(RECORDS[0])
    del bad["goals"]
    with pytest.raises(ValueError, match=r"procedural:val/0#0.*goals"):
        compute_metrics([bad])
    bad = dict(RECORDS[0], termination="exploded")
    with pytest.raises(ValueError, match="exploded"):
        compute_metrics([bad])


def test_jsonl_roundtrip_and_torn_tail(tmp_path):
    path = tmp_path / "episodes.jsonl"
    write_records(path, RECORDS)
    assert metrics_from_jsonl(path) == compute_metrics(RECORDS)
    with open(path, "a") as f:
        f.write('{"scene_id": "procedural:val/0", "episo')  # an append cut short
    with pytest.raises(ValueError, match=r"episodes.jsonl:5"):
        read_records(path)
    assert read_records(path, drop_partial_tail=True) == json.loads(json.dumps(RECORDS))


def test_tracker_builds_records():
    t = EpisodeTracker("procedural:val/1", 1, 3, "procedural:val/1#3")
    t.new_goal(4.5)
    for _ in range(4):
        t.step(0.25, False)
    t.step(0.0, False)
    t.goal_reached()
    t.new_goal(6.0)
    t.step(0.1, True)
    rec = t.finish("collision")
    assert rec["goals_reached"] == 1 and rec["first_goal_success"] and rec["collisions"] == 1
    assert rec["steps"] == 6 and math.isclose(rec["path_length"], 1.1) and rec["d0"] == 4.5
    assert [g["reached"] for g in rec["goals"]] == [True, False]
    m = compute_metrics([rec])
    assert m["SPL_1"] == pytest.approx(1.0) and m["CPK"] == pytest.approx(1 / 0.0011)
    with pytest.raises(ValueError, match="termination"):
        EpisodeTracker("s", 0, 0, "s#0").finish("bored")


def test_eval_run_written_before_the_benchmark_package_resumes(tmp_path):
    """run.json of an rvn-eval out_dir written when the reference policies lived in rvn_data.policies:
    its records are kept; any other difference is still refused."""
    from rvn_data.benchmark.results import RunDir

    ident = {"policy": {"_target_": "rvn_data.benchmark.policies.RandomPolicy"}, "split": "val"}
    old = {"policy": {"_target_": "rvn_data.policies.RandomPolicy"}, "split": "val"}
    (tmp_path / "run.json").write_text(json.dumps(old))
    (tmp_path / "episodes.jsonl").write_text(json.dumps({"scene_index": 0, "episode_index": 1}) + "\n")
    assert list(RunDir(tmp_path, ident).open()) == [(0, 1)]
    other = {"policy": {"_target_": "rvn_data.benchmark.policies.OraclePolicy"}, "split": "val"}
    with pytest.raises(ValueError, match="policy._target_"):
        RunDir(tmp_path, other).open()


def test_goal_ends_and_cpk_outside_timed_out_stretches():
    """How goals ended and CPK without the kilometres driven towards a goal that timed out (issue 31)."""
    m = compute_metrics(RECORDS)
    # goals reached: 2 + 1; the last goal of each failed episode ends with its termination
    assert m["goal_ends"] == {"success": 3, "collision": 2, "timeout": 2, "stop_far": 0}
    # 20.5 m in all; the timed-out stretches are episode 1's last goal (2 m) and episode 3's (0 m)
    assert m["CPK"] == pytest.approx(2 / 0.0205) and m["CPK_excl_timeout"] == pytest.approx(2 / 0.0185)
    assert "policy_stats" not in m
    with_stats = [{**r, "policy_stats": {"vetoes": i, "decisions": 10}} for i, r in enumerate(RECORDS)]
    assert compute_metrics(with_stats)["policy_stats"] == {"vetoes": 6, "decisions": 40}
    only_timeout = compute_metrics([RECORDS[3]])  # nothing driven outside a timed-out stretch, no collision
    assert only_timeout["CPK_excl_timeout"] == 0.0


def test_run_records_the_code_and_who_resumed_it(tmp_path, monkeypatch):
    """run.json and metrics.json carry the provenance of the code that started the run; a resume by other
    code (another commit) is recorded beside it, and the report shows both commits for that row."""
    from rvn_data.benchmark import results
    from rvn_data.benchmark.runs import load_run

    ident = {"policy": {"_target_": "rvn_data.benchmark.policies.RandomPolicy"}, "split": "val"}
    first = {"commit": "a" * 40, "code_commit": "a" * 40, "dirty": False, "version": "0.1.0", "generator_version": 2}
    later = {**first, "commit": "b" * 40, "code_commit": "b" * 40}
    monkeypatch.setattr(results, "provenance", lambda: first)
    run = results.RunDir(tmp_path, ident)
    run.open()
    run.append(RECORDS[0])
    assert json.loads((tmp_path / "run.json").read_text())["provenance"] == first
    monkeypatch.setattr(results, "provenance", lambda: later)
    run = results.RunDir(tmp_path, ident)
    assert list(run.open()) == [(0, 0)]
    # resumed, nothing added yet (a rerun of a finished evaluation adds nothing): the record is the first code's
    assert json.loads((tmp_path / "run.json").read_text()) == {**ident, "provenance": first}
    run.finish([RECORDS[0]], {**compute_metrics([RECORDS[0]]), "split": "val"}, "table\n")
    assert "resumed_by" not in json.loads((tmp_path / "metrics.json").read_text())
    run = results.RunDir(tmp_path, ident)
    run.open()
    run.append(RECORDS[1])
    stored = json.loads((tmp_path / "run.json").read_text())
    assert stored["provenance"] == first and stored["resumed_by"] == [later]
    recs = [RECORDS[0], RECORDS[1]]
    run.finish(recs, {**compute_metrics(recs), "split": "val"}, "table\n")
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["provenance"] == first and metrics["resumed_by"] == [later] and len(metrics["episode_set"]) == 12
    assert load_run(tmp_path).commits == ["aaaaaaa", "bbbbbbb"]
    # a fresh start (nothing to resume) is this code's alone
    run = results.RunDir(tmp_path, ident)
    run.open(resume=False)
    assert "resumed_by" not in json.loads((tmp_path / "run.json").read_text())


def test_a_record_written_in_parts_is_appended_whole(tmp_path, monkeypatch):
    """os.write may store part of what it is given (a full disk): the rest follows, so the next record does not sit
    behind a torn line that a resume could not drop (only a torn last line is dropped)."""
    from rvn_data.benchmark import results

    ident = {"policy": {"_target_": "rvn_data.benchmark.policies.RandomPolicy"}, "split": "val"}
    run = results.RunDir(tmp_path, ident)
    run.open()
    write = os.write
    monkeypatch.setattr(results.os, "write", lambda fd, data: write(fd, bytes(data[:7])))
    run.append(RECORDS[0])
    run.append(RECORDS[1])
    monkeypatch.undo()
    assert list(results.RunDir(tmp_path, ident).open()) == [(0, 0), (0, 1)]
    assert [json.loads(line) for line in (tmp_path / "episodes.jsonl").read_text().splitlines()] == RECORDS[:2]


def test_the_model_files_a_policy_loaded_are_part_of_the_eval_run(tmp_path):
    """The folders a loaded policy names as ``loaded_files`` (an RL policy's frozen depth model) count in the run's
    identity beside its checkpoint folder, so resuming after that model was retrained in place is refused; a run.json
    from before they were counted resumes."""
    from rvn_data.benchmark.results import RunDir, run_identity

    depth = tmp_path / "depth"
    depth.mkdir()
    (depth / "model.json").write_text('{"kind": "rvn_rl.depth"}')
    (depth / "model.safetensors").write_bytes(b"weights 1")
    ckpt = tmp_path / "rl"
    ckpt.mkdir()
    (ckpt / "config.yaml").write_text("kind: rl\n")

    def ident(loaded=None):
        return run_identity({"policy": {"_target_": "rvn_il.policies.load_policy", "checkpoint_path": str(ckpt)},
                             "split": "val"}, loaded)

    out = tmp_path / "eval"
    loaded = {"depth_model_path": str(depth)}
    first = ident(loaded)
    assert set(first["policy_files"]) == {"checkpoint_path", "depth_model_path"}
    assert set(ident()["policy_files"]) == {"checkpoint_path"}
    RunDir(out, first).open()
    (out / "episodes.jsonl").write_text(json.dumps({"scene_index": 0, "episode_index": 1}) + "\n")
    assert list(RunDir(out, ident(loaded)).open()) == [(0, 1)]  # the same files: resumed
    (depth / "model.safetensors").write_bytes(b"weights 2")  # the depth model retrained in place
    with pytest.raises(ValueError, match="policy_files.depth_model_path"):
        RunDir(out, ident(loaded)).open()
    stored = json.loads((out / "run.json").read_text())  # a run.json from before the depth model was counted
    del stored["policy_files"]["depth_model_path"]
    (out / "run.json").write_text(json.dumps(stored))
    assert list(RunDir(out, ident(loaded)).open()) == [(0, 1)]
    # the checkpoint folder reached by another path (a link to it): the same files, the same run, resumed; run.json
    # names the path it was last reached by. Other files under the other path: refused
    (tmp_path / "link").symlink_to(ckpt)
    ckpt = tmp_path / "link"
    assert list(RunDir(out, ident(loaded)).open()) == [(0, 1)]
    assert json.loads((out / "run.json").read_text())["policy"]["checkpoint_path"] == str(tmp_path / "link")
    ckpt = tmp_path / "rl2"
    ckpt.mkdir()
    (ckpt / "config.yaml").write_text("kind: rl\nother: 1\n")
    with pytest.raises(ValueError, match="checkpoint_path"):
        RunDir(out, ident(loaded)).open()
