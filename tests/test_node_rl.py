"""benchmarks/node.py's RL rows (node_rl.py, node_rl_runs.py, node_rl_ladder.py, rl.py, rl_env_phases.py; issue 32):
the learner's profile, the envs-alone rows, --skip, the env workers' layouts and the ladder of levers (recorded on a
CUDA plan where they need a GPU, run for real at tiny sizes where they do not). Their figures are not checked (no
timed assertions)."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_learner_profile_names_the_phases_of_an_update(monkeypatch, tmp_path):
    """rl.learner_profile (node.py's RL rows with --profile): the operator table of rvn-rl's learner side of one
    update without the envs, with the host's time per phase (act, storage, returns, update)."""
    from types import SimpleNamespace

    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import rl as rl_bench
    from rvn_rl.cli import compose

    args = SimpleNamespace(size=32, envs=2, workers=0, scenes=2, base_planes=8, num_steps=4, threads=1,
                           renderer="raycast", updates=1, goal_pool=8, ppo_epoch=1, mini_batches=1)
    text = rl_bench.learner_profile(compose(rl_bench.overrides(args, str(tmp_path / "run"))))
    (line,) = [x for x in text.splitlines() if x.startswith("host time per phase")]
    assert [p.split()[0] for p in line.split(": ", 1)[1].split(", ")] == ["act", "storage", "returns", "update"], line
    assert "aten::convolution" in text or "aten::conv2d" in text


def test_collection_runs_on_until_its_seconds_have_passed(monkeypatch, tmp_path):
    """rl.collection (node.py's envs-alone rows): the batched steps asked for, then more until ``seconds`` have
    passed, so that a fast node's figure holds as many scene switches as a slow one's (the fourth GPU run's rows
    were 128 steps, ~1 s, and held one stall or none); each timed step's seconds are given back and counted."""
    from types import SimpleNamespace

    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import rl as rl_bench
    from rvn_rl.cli import compose

    args = SimpleNamespace(size=32, envs=2, workers=0, scenes=2, base_planes=8, num_steps=4, threads=1,
                           renderer="raycast", updates=1, goal_pool=8, ppo_epoch=1, mini_batches=1)
    cfg = compose(rl_bench.overrides(args, str(tmp_path / "run")))
    times = []
    assert rl_bench.collection(cfg, 3, False, times) > 0 and len(times) == 3
    times = []
    rate = rl_bench.collection(cfg, 3, False, times, seconds=0.5)
    assert sum(times) >= 0.5 * 0.9 and len(times) > 3 and (len(times) - 3) % 8 == 0
    assert rate == pytest.approx(2 * len(times) / sum(times), rel=0.5)  # every timed step counted


def test_envs_rows_with_more_envs_a_worker_or_another_renderer(monkeypatch, tmp_path):
    """node.py's envs-alone rows that ask whether GL's calls from many processes bound the envs on a GPU node
    (run there after rl_envs): ``per_worker`` envs in each worker (row rl_envs_<workers>x<per_worker>, whose worker
    renders their views in one call) and another renderer (row rl_envs_<renderer>), each naming its ratio to the
    rl_envs row's rate; here on a --quick plan."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node as node_bench
    import node_rl_runs

    from types import SimpleNamespace

    plan = node_bench.make_plan(node_bench.parse(["--quick"]), False, 2)
    plan = SimpleNamespace(**vars(plan), rl_cache=str(tmp_path / "cache"), rl_filled="over a cache root of its own")
    small = dict(size=plan.rl_size, backbone="resnet18", num_steps=plan.rl_num_steps, ppo_epoch=4, mini_batches=1)
    wide = node_rl_runs.rl_envs_row(plan, small, workers=1, per_worker=3, against=100.0)
    assert wide["key"] == "rl_envs_1x3" and wide["value"] > 0, wide
    assert "1 worker(s) x 3 envs" in wide["label"] and "3 envs in 1 worker processes" in wide["settings"]
    assert re.search(r"; x[\d.]+ the rl_envs row's 100$", wide["settings"]), wide["settings"]
    other = node_rl_runs.rl_envs_row(plan, small, renderer="raycast", against=100.0)
    assert other["key"] == "rl_envs_raycast" and "renderer=raycast" in other["label"]
    assert "renderer=raycast, 2 envs in 1 worker processes" in other["settings"], other["settings"]


def test_skip_leaves_an_rl_row_out_and_names_it(monkeypatch):
    """node.py --skip ROW (a row a lease has measured already): the row is named as skipped in the table, nothing runs
    (rvn-rl's trainer would fail on the missing cache root here); an unknown row is an argparse error."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node as node_bench
    import node_rl_runs

    plan = node_bench.make_plan(node_bench.parse(["--quick", "--skip", "rl_compiled", "rl_overlap"]), False, 2)
    assert plan.skip == ["rl_compiled", "rl_overlap"]
    r = node_rl_runs.rl_row(plan, "rl_overlap", "scale=small, train.overlap=true", {}, "rl", "")
    assert r["key"] == "rl_overlap" and r["value"] is None and "--skip" in r["skipped"], r
    with pytest.raises(SystemExit):
        node_bench.parse(["--skip", "rl"])


def _recorded_rl_rows(monkeypatch, values: dict | None = None) -> tuple:
    """node_rl's row functions recorded, not run (the CUDA rows need a GPU): (plan, scale=small's settings, the
    recorded rows: key, ratio's base, rvn-rl's overrides of train., ppo.rec, env.scene_switch, env.workers and
    env.num_envs); ``values``: the rate each key's row returns (100 else, 1 for an envs-alone row)."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node as node_bench
    import node_rl_runs
    import rl as rl_bench

    plan = node_bench.make_plan(node_bench.parse(["--quick"]), False, 2)
    seen = []

    def record(plan, key, what, settings, goal_key, baseline, against=None):
        args = node_rl_runs.rl_args(plan, settings, updates=2)
        seen.append((key, against, [o for o in rl_bench.overrides(args, "out") if o.startswith(
            ("train.", "ppo.rec", "env.scene_switch", "env.workers", "env.num_envs"))], what))
        return {"key": key, "value": (values or {}).get(key, 100.0)}

    def record_envs(plan, settings, workers=None, per_worker=None, **kw):
        key = f"rl_envs_{workers}x{per_worker}"
        seen.append((key, None, [], ""))
        return {"key": key, "value": (values or {}).get(key, 1.0)}
    monkeypatch.setattr(node_rl_runs, "rl_row", record)
    monkeypatch.setattr(node_rl_runs, "rl_envs_row", record_envs)
    small = dict(size=plan.rl_size, backbone="resnet18", num_steps=plan.rl_num_steps, ppo_epoch=4, mini_batches=1)
    return plan, small, seen


def test_graph_act_rows_run_rvn_rl_with_the_graphed_act(monkeypatch):
    """node.py's CUDA rows of train.graph_act (node_rl_ladder.graph_act_rows), a ladder: rvn-rl's overrides of each
    row carry train.graph_act=true, then train.overlap with ppo.recompute_advantages, then train.double_buffered, then
    Habitat's scene switches, last train.compile; each names its ratio to the rl row. Here the rows' runs are
    recorded, not run (they need a GPU)."""
    plan, small, seen = _recorded_rl_rows(monkeypatch)
    import node_rl_ladder

    keys = [r["key"] for r in node_rl_ladder.graph_act_rows(plan, small, 100.0)]
    assert keys == ["rl_graph_act", "rl_graph_act_overlap", "rl_graph_act_overlap_double_buffered",
                    "rl_graph_act_overlap_double_buffered_scene_steps", "rl_all_levers"]
    assert all(against == 100.0 and "train.graph_act=true" in o for _, against, o, _ in seen)
    steps = ("env.scene_switch_steps=10000", "env.scene_switch_every=0")
    ladder = [{"train.overlap=false", "train.double_buffered=false", "train.compile=false"},
              {"train.overlap=true", "ppo.recompute_advantages=true", "train.double_buffered=false", "train.compile=false"},
              {"train.overlap=true", "train.double_buffered=true", "train.compile=false"},
              {"train.overlap=true", "train.double_buffered=true", "train.compile=false", *steps},
              {"train.overlap=true", "train.double_buffered=true", "train.compile=true", *steps}]
    for (_, _, overrides, _), want in zip(seen, ladder, strict=True):
        assert want <= set(overrides), (want, overrides)
        assert f"env.workers={plan.rl_workers}" in overrides  # scale=small's layout: base sets no workers
    assert not any(x.startswith("env.scene_switch") for _, _, o, _ in seen[:3] for x in o)  # rvn-rl's default switches


def test_env_worker_layouts(monkeypatch):
    """node_rl_ladder's layouts: the fat one (fewer workers, more envs each: fewer GL calls a batched step) and every
    layout of 2-10 envs a worker that the envs-alone rows time."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node_rl_ladder as ladder

    assert [ladder.fat_workers(n) for n in (30, 32, 16, 2, 3, 1)] == [6, 8, 4, 2, 3, 1]
    assert ladder.layouts(30, 15) == [(15, 2), (10, 3), (6, 5), (5, 6), (3, 10)]
    assert ladder.layouts(8, 8) == [(4, 2), (2, 4), (1, 8)] and ladder.layouts(2, 1) == [(1, 2)]
    assert ladder.layouts(7, 7) == [(1, 7)]
    assert ladder.layouts(11, 11) == []  # 11 x 1 or 1 x 11 only
    assert ladder.layouts(32, 8) == [(8, 4), (4, 8)]  # 2 x 16: more than MAX_ENVS_A_WORKER


@pytest.mark.parametrize("fastest, rate", [("rl_envs_5x6", 150.0), ("rl_envs_3x10", 50.0), ("rl_envs_15x2", None)])
def test_ladder_builds_on_the_faster_layout(monkeypatch, fastest, rate):
    """With CUDA, node_rl.rl_rows runs the rl row, the envs alone in each layout, then ``rl_workers_<W>`` in the
    fastest layout's workers (naming its ratio to rl; none where that is rl's own 15 workers), then the ladder on the
    faster of the two runs' layouts: env.workers=W in every ladder row's overrides and label when rl_workers_<W> was
    faster, scale=small's 15 workers when not. With --skip rl_layouts, rl_workers_6 (`fat_workers`). Recorded, not
    run (a 16-CPU CUDA plan)."""
    workers = {"rl_envs_5x6": 5, "rl_envs_3x10": 3, "rl_envs_15x2": 15}[fastest]
    plan, small, seen = _recorded_rl_rows(monkeypatch, {"rl": 100.0, fastest: 9.0, f"rl_workers_{workers}": rate})
    import node as node_bench
    import node_rl
    import node_rl_runs

    plan = node_bench.make_plan(node_bench.parse(["--skip", "rl_envs", "rl_paper", "rl_compiled", "rl_overlap",
                                                  "rl_scene_steps"]), True, 16)
    monkeypatch.setattr(node_rl_runs, "fill_scene_caches", lambda plan, settings, root: "over a recorded cache root")
    keys = [r["key"] for r in node_rl.rl_rows(plan)]
    fewer = [] if rate is None else [f"rl_workers_{workers}"]
    assert keys[:8 + len(fewer)] == ["rl", "rl_scene_steps", "rl_bf16", "rl_envs_15x2", "rl_envs_10x3", "rl_envs_6x5",
                                     "rl_envs_5x6", "rl_envs_3x10", *fewer], keys
    assert keys[8 + len(fewer):10 + len(fewer)] == ["rl_graph_act", "rl_graph_act_overlap"], keys
    rows = {key: (against, o, what) for key, against, o, what in seen}
    if fewer:
        against, overrides, _ = rows[fewer[0]]
        assert against == 100.0 and {f"env.workers={workers}", "env.num_envs=30"} <= set(overrides)
    base = workers if rate is not None and rate > 100 else 15
    for key in ("rl_graph_act", "rl_graph_act_overlap_double_buffered", "rl_all_levers"):
        against, overrides, what = rows[key]
        assert against == 100.0 and {f"env.workers={base}", "env.num_envs=30"} <= set(overrides), (key, overrides)
        assert (f"env.workers={base}" in what) == (base != 15), what
    seen.clear()
    plan.skip.append("rl_layouts")
    keys = [r["key"] for r in node_rl.rl_rows(plan)]
    assert "rl_workers_6" in keys and not any(k.startswith("rl_envs_") for k in keys), keys


def test_a_failing_rung_names_its_error_and_the_ladder_goes_on(monkeypatch):
    """A layout or ladder row that raises (none of them has run on a GPU) becomes a row naming its error, and the rows
    after it still run; a failed rl_workers_6 (6 x 5 the fastest layout) leaves the ladder on scale=small's layout."""
    plan, small, seen = _recorded_rl_rows(monkeypatch, {"rl_envs_6x5": 9.0})
    import node_rl_runs
    import node_rl_ladder

    recorded = node_rl_runs.rl_row

    def failing(plan, key, what, settings, *a, **k):
        if key in ("rl_workers_6", "rl_graph_act_overlap"):
            raise RuntimeError(f"CUDA error in {key}\nsecond line")
        return recorded(plan, key, what, settings, *a, **k)
    monkeypatch.setattr(node_rl_runs, "rl_row", failing)
    plan.rl_envs, plan.rl_workers = 30, 15
    rows = list(node_rl_ladder.layout_rows(plan, small, {"key": "rl", "value": 100.0}))
    fewer = rows[-1]
    assert fewer["key"] == "rl_workers_6" and fewer["value"] is None
    assert fewer["error"] == "RuntimeError: CUDA error in rl_workers_6" and "env.workers=6" in fewer["label"]
    assert [r["key"] for r in rows[:-1]] == ["rl_envs_15x2", "rl_envs_10x3", "rl_envs_6x5", "rl_envs_5x6",
                                             "rl_envs_3x10"]
    gen = node_rl_ladder.layout_rows(plan, small, {"key": "rl", "value": 100.0})
    try:
        while True:
            next(gen)
    except StopIteration as stop:
        assert stop.value == small  # the failed layout is not the ladder's base
    ladder = list(node_rl_ladder.graph_act_rows(plan, small, 100.0))
    assert [r["key"] for r in ladder] == ["rl_graph_act", "rl_graph_act_overlap", "rl_graph_act_overlap_double_buffered",
                                          "rl_graph_act_overlap_double_buffered_scene_steps", "rl_all_levers"]
    assert [bool(r.get("error")) for r in ladder] == [False, True, False, False, False]


@pytest.mark.slow
def test_layout_rows_run_rvn_rl_in_fewer_workers(monkeypatch, tmp_path):
    """node_rl_ladder.layout_rows for real at tiny sizes on the CPU (on a node they run with CUDA): the envs alone in
    each layout of 2-10 envs a worker of the plan's 4 envs (2 x 2, 1 x 4), then rvn-rl's run in the faster layout's
    workers instead of 4 of 1 (row rl_workers_<W>, its label and settings naming them); the ladder's base takes the
    faster run's workers."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    from types import SimpleNamespace

    import node as node_bench
    import node_rl_runs
    import node_rl_ladder

    plan = node_bench.make_plan(node_bench.parse(["--quick"]), False, 2)
    plan = SimpleNamespace(**{**vars(plan), "rl_envs": 4, "rl_workers": 4, "rl_scenes": 2})
    small = dict(size=plan.rl_size, backbone="resnet18", num_steps=plan.rl_num_steps, ppo_epoch=1, mini_batches=1)
    kept = str(tmp_path / "cache")
    plan = SimpleNamespace(**vars(plan), rl_cache=kept, rl_filled=node_rl_runs.fill_scene_caches(plan, small, kept))
    gen = node_rl_ladder.layout_rows(plan, small, {"key": "rl", "value": 1e-6})
    rows = []
    try:
        while True:
            rows.append(next(gen))
    except StopIteration as stop:
        base = stop.value
    assert [r["key"] for r in rows[:2]] == ["rl_envs_2x2", "rl_envs_1x4"]
    assert all(r["value"] > 0 and not r["error"] for r in rows), rows
    assert "4 envs in 1 worker processes" in rows[1]["settings"], rows[1]
    w = 2 if rows[0]["value"] >= rows[1]["value"] else 1  # the fastest layout's workers
    assert rows[2]["key"] == f"rl_workers_{w}" and f"env.workers={w}" in rows[2]["label"], rows[2]
    assert f"x 4 envs, 1 epochs x 1 mini-batches, {w} env worker processes" in rows[2]["settings"], rows[2]
    assert base == {**small, "workers": w}  # faster than the 1e-6 env steps/s given as the rl row's


@pytest.mark.slow
def test_env_phases_benchmark_splits_the_envs_step_by_process_count(tmp_path):
    """benchmarks/rl_env_phases.py (what bounds rvn-rl's envs side by side) at a tiny size: the cache root filled, then
    one and two processes of 2 envs each, each line with the rate together and a process's, and the phases' ms; the
    two also through rvn-rl's worker processes; Habitat's scene switches (--scene-switch-steps) counted apart."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "rl_env_phases.py"), "--processes", "1", "2",
                           "--envs", "2", "--seconds", "0.5", "--warm", "0", "--scenes", "2", "--size", "64",
                           "--renderer", "raycast", "--scene-switch-steps", "100000", "--cache-dir",
                           str(tmp_path / "cache")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert re.search(r"cache root filled \(2 scenes' navmeshes and goal pools\)", proc.stdout), proc.stdout
    lines = [line for line in proc.stdout.splitlines() if "process(es):" in line]
    assert len(lines) == 2 and lines[0].lstrip().startswith("1 process") and lines[1].lstrip().startswith("2 process")
    pattern = (r"(\d+) env steps/s together, +(\d+) a process; a batched step's mean ([\d.]+) ms .*state steps "
               r"([\d.]+), rendering ([\d.]+), observations ([\d.]+) ms")
    for line in lines:
        together, per, step, state, render, observe = map(float, re.search(pattern, line).groups())
        assert together > 0 and per > 0 and render > 0
        assert state + render + observe == pytest.approx(step, abs=0.02)  # the phases split the step
    assert "against 1: step x1.00" in lines[0]
    # the two processes' envs also as rvn-rl steps them: worker processes, one process gathering them
    assert re.search(r"as rvn-rl steps them \(2 worker processes, one process gathering their observations each "
                     r"batched step\): \d+ env steps/s, x[\d.]+ the processes on their own", proc.stdout), proc.stdout
    # scene switches (env.scene_switch_steps): none within a short run, and resets are not counted as switches
    assert "a scene switch at the first reset after ~100000 steps in one" in proc.stdout, proc.stdout
    assert proc.stdout.count("scene switches in 0.0% of the steps: 0.00 ms a step") == 2, proc.stdout


def test_steady_updates_leave_out_a_runs_first_seconds(monkeypatch):
    """rl.steady_updates(rows, warm_seconds, envs): the first update always, then every update that began within
    ``warm_seconds`` of the run's start (an update's seconds: its env steps over its env steps/s); overlapped runs
    also leave their last update out."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import rl as rl_bench

    rows = [{"rollout_steps": 10, "fps": 20.0 * 4, "overlapped": 0, "k": k} for k in range(6)]  # 0.5 s each, 4 envs
    assert [r["k"] for r in rl_bench.steady_updates(rows)] == [1, 2, 3, 4, 5]
    assert [r["k"] for r in rl_bench.steady_updates(rows, 1.2, 4)] == [3, 4, 5]  # began at 0, 0.5, 1.0: warm-up
    assert [r["k"] for r in rl_bench.steady_updates(rows, 1.0, 4)] == [2, 3, 4, 5]
    assert rl_bench.steady_updates(rows, 10.0, 4) == []
    over = [{**r, "overlapped": float(r["k"] < 5)} for r in rows]
    assert [r["k"] for r in rl_bench.steady_updates(over, 1.2, 4)] == [3, 4]
