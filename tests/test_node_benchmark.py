"""benchmarks/node.py (issue 32): one table of every row on this machine. Its figures are not
checked (no timed assertions): every row is listed, GPU rows say they were skipped without CUDA,
measured figures are positive, and the JSON names the commit."""
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[1]
NODE = ROOT / "benchmarks" / "node.py"
GROUPS = {"render": 1, "gen": 2, "train": 3, "decision": 4, "rl": 5}


def node(*args, timeout=1500):
    return subprocess.run([sys.executable, str(NODE), *args], capture_output=True, text=True, timeout=timeout, cwd=ROOT)


@pytest.mark.slow
def test_quick_run_lists_every_row(tmp_path):
    proc = node("--quick", "--out", str(tmp_path / "out"))
    assert proc.returncode == 0, proc.stdout + proc.stderr[-3000:]
    doc = json.loads((tmp_path / "out" / "node.json").read_text())
    table = (tmp_path / "out" / "node.md").read_text()
    assert table in proc.stdout
    rows = {r["key"]: r for r in doc["rows"]}
    cpus = doc["cpu_count"]
    expected = {"gen", "train_nomad_pointgoal", "train_vint_pointgoal", "decision_gpu", "decision_cpu",
                "rl", "rl_scene_steps", "rl_bf16", "rl_overlap", "rl_compiled", "rl_envs", "rl_envs_no_prefetch", "rl_envs_1", "rl_envs_fresh_goals",
                "rl_envs_first_pass", "render_gl_4scenes"}
    expected |= {f"render_{b}_{n}p" for b in ("gl", "raycast") for n in {1, 2, cpus}}
    assert expected <= set(rows), sorted(expected - set(rows))
    assert {r["group"] for r in doc["rows"]} == set(GROUPS.values())
    assert "env.prefetch_scenes=false" in rows["rl_envs_no_prefetch"]["label"]
    assert "with env.prefetch_scenes (rl_envs): x" in rows["rl_envs_no_prefetch"]["settings"]
    assert "env.goal_pool=0" in rows["rl_envs_fresh_goals"]["label"]
    assert "goal pool 0" in rows["rl_envs_fresh_goals"]["settings"]
    assert "with the goal pool of 64 (rl_envs): x" in rows["rl_envs_fresh_goals"]["settings"]
    assert "over an empty cache root" in rows["rl_envs_first_pass"]["settings"]
    assert "train.precision=bf16" in rows["rl_bf16"]["label"]
    assert "env.scene_switch_steps=10000, env.scene_switch_every=0" in rows["rl_scene_steps"]["label"]
    for name in ("rl_bf16", "rl_overlap", "rl_scene_steps"):
        if rows[name]["skipped"]:  # --quick on a CPU that emulates bfloat16 (rvn_rl.trainer.native_bf16_cpu)
            assert name == "rl_bf16" and "bfloat16 is emulated on this CPU" in rows[name]["skipped"]
            continue
        assert re.match(r"x[\d.]+ the rl row's \d+ \(float32, not compiled\)", rows[name]["baseline"])
    from rvn_rl.trainer import native_bf16_cpu
    assert bool(rows["rl_bf16"]["skipped"]) == (doc["device"] == "CPU only" and not native_bf16_cpu())
    assert "train.overlap=true, ppo.recompute_advantages=true" in rows["rl_overlap"]["label"]
    assert rows["rl_compiled"]["skipped"] if doc["device"] == "CPU only" else rows["rl_compiled"]["value"] > 0
    if doc["device"] == "CPU only":
        assert "CUDA graphs need a GPU" in rows["rl_graph_act"]["skipped"]
    assert "over the kept caches (rl_envs): x" in rows["rl_envs_first_pass"]["settings"]
    for name in ("rl", "rl_envs", "rl_envs_1"):  # the scenes' navmeshes and pools made before the rows
        assert re.search(r"over a cache root holding the \d+ scenes' navmeshes and goal pools", rows[name]["settings"])
    # switch waits show in the tail
    for name in ("rl_envs", "rl_envs_no_prefetch", "rl_envs_1", "rl_envs_fresh_goals", "rl_envs_first_pass"):
        assert re.search(r"batched step median [\d.]+ ms, 90th [\d.]+, 99th [\d.]+, slowest \d+", rows[name]["settings"])
    for r in doc["rows"]:
        assert f"| {r['group']} | {r['label']} |" in table
        assert r["error"] is None, r
        if r["skipped"]:
            assert f"skipped: {r['skipped']}" in table
        else:
            assert r["value"] > 0, r
    gpu_rows = [r for r in doc["rows"] if r["key"] == "decision_gpu"]
    if torch.cuda.is_available():
        assert not gpu_rows[0]["skipped"] and doc["device"] != "CPU only"
    else:
        assert "no CUDA" in gpu_rows[0]["skipped"] and doc["device"] == "CPU only"
        assert "skipped: no CUDA" in proc.stdout
        assert all(r["ratio"] is None for r in doc["rows"])  # goals are compared on a GPU node only
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True)
    if head.returncode == 0:
        assert doc["commit"] == head.stdout.strip()
    assert doc["commit"] and doc["commit"] in json.dumps(doc["provenance"])
    assert doc["torch"] == torch.__version__ and doc["quick"] is True
    assert doc["cpu"]["scaling"]["ratio"] > 0 and doc["cpu"]["scaling"]["processes"] == cpus
    assert f"CPUs: {doc['cpu']['model']}; cgroup CPU quota: " in table
    assert "numba kernels loaded from the cache in " in table or "numba kernels compiled (a fresh install)" in table
    assert not list((tmp_path / "out").glob(".*tmp"))  # written atomically, no temporary files left


@pytest.mark.parametrize("args, says", [(["--seconds-per-row", "0"], "--seconds-per-row"),
                                        (["--rows", "nope"], "invalid choice"),
                                        (["--compile-mode", "max-autotune"], "invalid choice"),
                                        (["--loader-workers", "-1"], "--loader-workers=-1 must be >= 0"),
                                        (["--bogus"], "unrecognized arguments")])
def test_bad_options_one_line_exit_2(args, says):
    proc = node(*args, timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], proc.stderr


def test_out_must_be_a_folder(tmp_path):
    (tmp_path / "f").write_text("")
    proc = node("--out", str(tmp_path / "f"), timeout=120)
    assert proc.returncode == 2 and "is a file" in proc.stderr and proc.stdout == ""


@pytest.mark.slow
def test_render_parallel_for_a_time_budget():
    """render_parallel(seconds=...) (node.py's renderer rows): the poses over and over for that long, no images kept."""
    import numpy as np

    from rvn_data.render import CameraConfig
    from rvn_data.render.parallel import render_parallel

    poses, cam = [(np.array([0.0, 0.0, 0.0]), y) for y in (0.0, 1.0)], CameraConfig(width=16, height=16)
    out = render_parallel("procedural:train/0", cam, poses, "raycast", processes=1, seconds=0.3)
    assert out.rgb is None and out.depth is None and out.frames >= 1 and out.frames_per_second > 0
    with pytest.raises(ValueError, match="seconds"):
        render_parallel("procedural:train/0", cam, poses, "raycast", seconds=0)


def test_goals_compared_on_a_gpu_node_only():
    """The table of a (simulated) GPU node: goal, measured/goal and met per row; without CUDA only the goal."""
    sys.path.append(str(ROOT / "benchmarks"))
    import node_report
    from node_rows import row

    info = {"device": "NVIDIA H200", "cuda": True, "gpus": 1, "cuda_version": "13.0", "cpu_count": 16, "torch": "2.11",
            "date": "2026-11-26", "provenance": {"commit": "0123456789abcdef", "dirty": False}}
    rows = [row(3, "train_nomad_pointgoal", "rvn-train nomad_pointgoal (cuda)", "samples/s", "train_nomad_pointgoal",
                5000.0, gpu_busy=0.9),
            row(4, "decision_gpu", "NoMaD decision, GPU", "ms", "decision_gpu", 12.0, gpu_busy=None),
            row(1, "render_raycast_1p", "renderer=raycast, 1 process", "frames/s", None, 100.0)]
    for r in rows:
        node_report.compare(r, cuda=True)
    assert (rows[0]["ratio"], rows[0]["met"]) == (1.25, True) and (rows[1]["ratio"], rows[1]["met"]) == (1.2, False)
    assert rows[2]["goal"] is None and rows[2]["ratio"] is None
    text = node_report.markdown(info, rows, {"quick": False, "seconds": 15.0})
    assert "| >= 4,000 samples/s | 1.25 (met) | 90% |" in text and "| <= 12.0 ms" not in text
    assert "| 12.0 ms | <= 10.0 ms | 1.20 (not met) | n/a |" in text and "commit 0123456789" in text
    node_report.compare(rows[0], cuda=False)
    assert rows[0]["ratio"] is None and rows[0]["goal"] == {"op": ">=", "value": 4000.0}


def test_the_plain_figure_comes_before_the_compiled_one(capsys):
    """The plain path is measured (and so written) before the compiled one, whose first compile can outlast a GPU
    node's time limit; a compiled path that fails (untried on a new node) is named after the plain figure; a plain
    path that fails is an error of the row."""
    sys.path.append(str(ROOT / "benchmarks"))
    from node_rows import plain_then_compiled

    def measure(compiled: bool):
        if compiled:
            raise RuntimeError("CUDA graphs: no\nmore lines")
        return 40.0

    assert list(plain_then_compiled(measure, True)) == [("plain", 40.0), ("failed", "RuntimeError: CUDA graphs: no")]
    assert "CUDA graphs: no" in capsys.readouterr().err  # the traceback, for whoever reads the run's log
    assert list(plain_then_compiled(lambda compiled: 31.0 if compiled else 50.0, True)) == [("plain", 50.0),
                                                                                          ("compiled", 31.0)]
    assert list(plain_then_compiled(measure, False)) == [("plain", 40.0)]
    with pytest.raises(ZeroDivisionError):
        list(plain_then_compiled(lambda compiled: 1 / 0, True))


@pytest.mark.slow
def test_the_table_is_written_after_each_row(tmp_path):
    """A run cut short (a GPU node's time limit) keeps the rows it finished: node.md and node.json are
    rewritten after each row, here read as soon as the first one appears, while the rest still runs; the groups
    run in the order --rows names them."""
    import time

    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, str(NODE), "--quick", "--rows", "decision", "rl", "--out", str(out)],
                            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 600
        while not (out / "node.json").exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        first = json.loads((out / "node.json").read_text())
        assert proc.poll() is None, "the run ended before the first row's table was read"
    finally:
        proc.kill()
        proc.wait()
    assert first["rows"][0]["key"] == "decision_gpu" and {r["group"] for r in first["rows"]} == {GROUPS["decision"]}
    assert "NoMaD decision, GPU" in (out / "node.md").read_text()


@pytest.mark.slow
def test_profile_writes_an_operator_table_per_row(tmp_path):
    """--profile on: torch.profiler's operator table of the decision row, beside node.md, named in node.json."""
    proc = node("--quick", "--rows", "decision", "--profile", "on", "--out", str(tmp_path), timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = {r["key"]: r for r in json.loads((tmp_path / "node.json").read_text())["rows"]}
    assert rows["decision_cpu"]["profile"] == "profile_decision_cpu.txt" and rows["decision_gpu"]["profile"] is None
    table = (tmp_path / "profile_decision_cpu.txt").read_text()
    assert table.startswith("NoMaD decision, one CPU thread: ") and "policy.act" in table and "aten::" in table
    assert "by Python function" in table  # the host's side, named by function
    assert "profile_decision_cpu.txt" in (tmp_path / "node.md").read_text()


def test_environ_sets_and_restores(monkeypatch):
    """node_rows.environ (the __GL_YIELD=USLEEP rows): set while the block runs, as before afterwards."""
    sys.path.append(str(ROOT / "benchmarks"))
    import os

    from node_rows import environ

    monkeypatch.setenv("RVN_T_KEPT", "a")
    monkeypatch.delenv("RVN_T_NEW", raising=False)
    with environ({"RVN_T_KEPT": "b", "RVN_T_NEW": "c"}):
        assert (os.environ["RVN_T_KEPT"], os.environ["RVN_T_NEW"]) == ("b", "c")
    assert os.environ["RVN_T_KEPT"] == "a" and "RVN_T_NEW" not in os.environ
    with environ(None):
        assert os.environ["RVN_T_KEPT"] == "a"


def test_warm_compiles_each_row_in_a_process_of_its_own(monkeypatch):
    """node.py --warm (node_warm.warm): one process per compiled row, each with its time limit; a job that fails or
    runs out of time is reported in one line (its row then compiles cold), and nothing is left running."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node
    import node_warm

    plan = node.make_plan(node.parse(["--quick", "--compile", "on"]), False, 2)
    assert plan.loader_workers == 0 and node.make_plan(node.parse(["--loader-workers", "3"]), True, 16).loader_workers == 3
    assert node.make_plan(node.parse([]), True, 16).loader_workers == 16  # one per CPU on a GPU node
    assert node_warm.jobs(plan, ["train", "decision", "rl"]) == [
        "train_nomad_pointgoal", "train_vint_pointgoal", "decision_cpu"]
    assert node_warm.jobs(node.make_plan(node.parse(["--quick", "--compile", "off"]), False, 2), ["train"]) == []
    both = node.make_plan(node.parse(["--quick", "--compile", "on", "--compile-mode", "default", "reduce-overhead"]),
                          False, 2)
    assert node_warm.jobs(both, ["train"]) == ["train_nomad_pointgoal", "train_vint_pointgoal",
                                               "train_nomad_pointgoal@reduce-overhead",
                                               "train_vint_pointgoal@reduce-overhead"]
    assert node_warm.numba_kernels(["train", "decision"]) is None  # no row of these runs them in workers
    plan.decision_cpu_size = "nope"  # the job's own error, in its line
    (line,) = node_warm.warm(plan, ["decision"], 300)
    assert line.startswith("decision_cpu: ") and "FAILED" in line and "model.size='nope'" in line, line
    plan.decision_cpu_size = "small"  # a cold compile of minutes, stopped at its limit
    (line,) = node_warm.warm(plan, ["decision"], 1)
    assert line == "decision_cpu: stopped after 1 s (its row compiles the rest)", line


def test_cpu_probe_reads_the_quota_and_times_processes_side_by_side(monkeypatch, tmp_path):
    """node_cpu (node.md's header): the cgroup quota from cgroup v2 or v1 files (None without a limit), and the
    probe's loop alone and in two processes at once, as rates and their ratio."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node_cpu

    (tmp_path / "cpu.max").write_text("max 100000\n")
    assert node_cpu.cpu_quota(tmp_path) is None
    (tmp_path / "cpu.max").write_text("800000 100000\n")
    assert node_cpu.cpu_quota(tmp_path) == 8.0
    v1 = tmp_path / "v1"
    (v1 / "cpu").mkdir(parents=True)
    (v1 / "cpu" / "cpu.cfs_quota_us").write_text("150000\n")
    (v1 / "cpu" / "cpu.cfs_period_us").write_text("100000\n")
    assert node_cpu.cpu_quota(v1) == 1.5
    (v1 / "cpu" / "cpu.cfs_quota_us").write_text("-1\n")
    assert node_cpu.cpu_quota(v1) is None and node_cpu.cpu_quota(tmp_path / "absent") is None
    info = node_cpu.cpu_info(2, 0.2)
    s = info["scaling"]
    assert s["processes"] == 2 and s["alone"] > 0 and 0 < s["slowest"] <= s["side_by_side"]
    assert s["ratio"] == pytest.approx(s["side_by_side"] / s["alone"])
    line = node_cpu.describe(info, 2)
    assert line.startswith(f"CPUs: {info['model']}; cgroup CPU quota: ") and "with 2 side by side" in line
    assert node_cpu.describe({"error": "RuntimeError: boom"}, 2) == "CPUs: the probe FAILED (RuntimeError: boom)"


def test_profile_gives_each_phase_and_the_python_functions(monkeypatch):
    """op_profile.op_table: the host's time per `phase` of the steps and a cProfile table of the same steps."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    from op_profile import op_table, phase

    net = torch.nn.Linear(16, 4)

    def steps():
        for _ in range(3):
            with phase("forward"):
                loss = net(torch.randn(8, 16)).square().mean()
            with phase("backward"):
                loss.backward()

    text = op_table(steps, False, rows=10)
    assert "aten::addmm" in text and "step: forward" in text
    (line,) = [x for x in text.splitlines() if x.startswith("host time per phase")]
    assert [p.split()[0] for p in line.split(": ", 1)[1].split(", ")] == ["forward", "backward"], line
    python = text[text.index("by Python function"):]
    assert "run_backward" in python and "linear" in python


def test_gpu_busy_of_a_row_is_that_of_its_timed_steps(monkeypatch, tmp_path):
    """A training or decision row's GPU busy share is the mean of the samples taken while its timed steps ran
    (`steady_train_rate` and `decision_ms` give that window), not of its set-up, compiling and warm-up."""
    import time

    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import decision as decision_bench
    import train as train_bench
    from node_report import GpuBusy

    from rvn_il.data.synthetic import write_synthetic_gnm
    from rvn_il.models import load_model_config

    busy = GpuBusy()
    busy.samples, busy.share = [(1.0, 10.0), (2.0, 80.0), (3.0, 100.0), (4.0, 20.0)], 0.525
    assert busy.share_in([1.5, 3.5]) == pytest.approx(0.9)
    assert busy.share_in([]) == busy.share_in([4.5, 5.0]) == 0.525  # no window, or no sample in it: the row's
    root = write_synthetic_gnm(tmp_path / "expert", 2, 12, image_size=32)
    before, window = time.perf_counter(), []
    rate, steps, _ = train_bench.steady_train_rate(root, load_model_config("vint_pointgoal", "small"), 4, 0.3,
                                                   cache_dir=str(tmp_path / "cache"), window=window)
    assert rate > 0 and steps > 0 and before < window[0] < window[1] <= time.perf_counter()
    before, window = time.perf_counter(), []
    ms, _ = decision_bench.decision_ms("nomad_pointgoal", "small", 3, reference=False, window=window)
    assert ms > 0 and before < window[0] < window[1] <= time.perf_counter()


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
    import node_rl

    from types import SimpleNamespace

    plan = node_bench.make_plan(node_bench.parse(["--quick"]), False, 2)
    plan = SimpleNamespace(**vars(plan), rl_cache=str(tmp_path / "cache"), rl_filled="over a cache root of its own")
    small = dict(size=plan.rl_size, backbone="resnet18", num_steps=plan.rl_num_steps, ppo_epoch=4, mini_batches=1)
    wide = node_rl._rl_envs_row(plan, small, workers=1, per_worker=3, against=100.0)
    assert wide["key"] == "rl_envs_1x3" and wide["value"] > 0, wide
    assert "1 worker(s) x 3 envs" in wide["label"] and "3 envs in 1 worker processes" in wide["settings"]
    assert re.search(r"; x[\d.]+ the rl_envs row's 100$", wide["settings"]), wide["settings"]
    other = node_rl._rl_envs_row(plan, small, renderer="raycast", against=100.0)
    assert other["key"] == "rl_envs_raycast" and "renderer=raycast" in other["label"]
    assert "renderer=raycast, 2 envs in 1 worker processes" in other["settings"], other["settings"]


def test_skip_leaves_an_rl_row_out_and_names_it(monkeypatch):
    """node.py --skip ROW (a row a lease has measured already): the row is named as skipped in the table, nothing runs
    (rvn-rl's trainer would fail on the missing cache root here); an unknown row is an argparse error."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node as node_bench
    import node_rl

    plan = node_bench.make_plan(node_bench.parse(["--quick", "--skip", "rl_compiled", "rl_overlap"]), False, 2)
    assert plan.skip == ["rl_compiled", "rl_overlap"]
    r = node_rl._rl_row(plan, "rl_overlap", "scale=small, train.overlap=true", {}, "rl", "")
    assert r["key"] == "rl_overlap" and r["value"] is None and "--skip" in r["skipped"], r
    with pytest.raises(SystemExit):
        node_bench.parse(["--skip", "rl"])


def _recorded_rl_rows(monkeypatch, values: dict | None = None) -> tuple:
    """node_rl's row functions recorded, not run (the CUDA rows need a GPU): (plan, scale=small's settings, the
    recorded rows: key, ratio's base, rvn-rl's overrides of train., ppo.rec, env.scene_switch, env.workers and
    env.num_envs); ``values``: the rate each key's row returns (100 else)."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node as node_bench
    import node_rl
    import rl as rl_bench

    plan = node_bench.make_plan(node_bench.parse(["--quick"]), False, 2)
    seen = []

    def record(plan, key, what, settings, goal_key, baseline, against=None):
        args = node_rl.rl_args(plan, settings, updates=2)
        seen.append((key, against, [o for o in rl_bench.overrides(args, "out") if o.startswith(
            ("train.", "ppo.rec", "env.scene_switch", "env.workers", "env.num_envs"))], what))
        return {"key": key, "value": (values or {}).get(key, 100.0)}

    def record_envs(plan, settings, workers=None, per_worker=None, **kw):
        seen.append((f"rl_envs_{workers}x{per_worker}", None, [], ""))
        return {"key": f"rl_envs_{workers}x{per_worker}", "value": 1.0}
    monkeypatch.setattr(node_rl, "_rl_row", record)
    monkeypatch.setattr(node_rl, "_rl_envs_row", record_envs)
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
    layout of 2-6 envs a worker that the envs-alone rows time."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import node_rl_ladder as ladder

    assert [ladder.fat_workers(n) for n in (30, 32, 16, 2, 3, 1)] == [6, 8, 4, 2, 3, 1]
    assert ladder.layouts(30, 15) == [(15, 2), (10, 3), (6, 5), (5, 6)]
    assert ladder.layouts(8, 8) == [(4, 2), (2, 4)] and ladder.layouts(2, 1) == [(1, 2)] and ladder.layouts(7, 7) == []


@pytest.mark.parametrize("fat_rate", [150.0, 50.0])
def test_ladder_builds_on_the_faster_layout(monkeypatch, fat_rate):
    """With CUDA, node_rl.rl_rows runs the rl row, then ``rl_workers_6`` (its 30 envs in 6 workers of 5, naming its
    ratio to rl), the envs alone in each layout, then the ladder on the faster of the two runs' layouts: env.workers=6
    in every ladder row's overrides and label when rl_workers_6 was faster, scale=small's 15 workers when not.
    --skip rl_layouts leaves the envs-alone layout rows out. Recorded, not run (a 16-CPU CUDA plan)."""
    plan, small, seen = _recorded_rl_rows(monkeypatch, {"rl": 100.0, "rl_workers_6": fat_rate})
    import node as node_bench
    import node_rl

    plan = node_bench.make_plan(node_bench.parse(["--skip", "rl_envs", "rl_paper", "rl_compiled", "rl_overlap",
                                                  "rl_scene_steps"]), True, 16)
    monkeypatch.setattr(node_rl, "fill_scene_caches", lambda plan, settings, root: "over a recorded cache root")
    keys = [r["key"] for r in node_rl.rl_rows(plan)]
    assert keys[:7] == ["rl", "rl_scene_steps", "rl_bf16", "rl_workers_6", "rl_envs_15x2", "rl_envs_10x3",
                        "rl_envs_6x5"], keys
    assert keys[7:11] == ["rl_envs_5x6", "rl_graph_act", "rl_graph_act_overlap",
                          "rl_graph_act_overlap_double_buffered"], keys
    rows = {key: (against, o, what) for key, against, o, what in seen}
    assert rows["rl_workers_6"][0] == 100.0 and {"env.workers=6", "env.num_envs=30"} <= set(rows["rl_workers_6"][1])
    workers = "env.workers=6" if fat_rate > 100 else "env.workers=15"
    for key in ("rl_graph_act", "rl_graph_act_overlap_double_buffered", "rl_all_levers"):
        against, overrides, what = rows[key]
        assert against == 100.0 and workers in overrides and "env.num_envs=30" in overrides, (key, overrides)
        assert ("env.workers=6" in what) == (fat_rate > 100), what
    seen.clear()
    plan.skip.append("rl_layouts")
    keys = [r["key"] for r in node_rl.rl_rows(plan)]
    assert "rl_workers_6" in keys and not any(k.startswith("rl_envs_") for k in keys), keys


def test_a_failing_rung_names_its_error_and_the_ladder_goes_on(monkeypatch):
    """A layout or ladder row that raises (none of them has run on a GPU) becomes a row naming its error, and the rows
    after it still run; a failed rl_workers_6 leaves the ladder on scale=small's layout."""
    plan, small, seen = _recorded_rl_rows(monkeypatch)
    import node_rl
    import node_rl_ladder

    recorded = node_rl._rl_row

    def failing(plan, key, what, settings, *a, **k):
        if key in ("rl_workers_6", "rl_graph_act_overlap"):
            raise RuntimeError(f"CUDA error in {key}\nsecond line")
        return recorded(plan, key, what, settings, *a, **k)
    monkeypatch.setattr(node_rl, "_rl_row", failing)
    plan.rl_envs, plan.rl_workers = 30, 15
    rows = list(node_rl_ladder.layout_rows(plan, small, {"key": "rl", "value": 100.0}))
    fat = rows[0]
    assert fat["key"] == "rl_workers_6" and fat["value"] is None
    assert fat["error"] == "RuntimeError: CUDA error in rl_workers_6" and "env.workers=6" in fat["label"]
    assert [r["key"] for r in rows[1:]] == ["rl_envs_15x2", "rl_envs_10x3", "rl_envs_6x5", "rl_envs_5x6"]
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
    """node_rl_ladder.layout_rows for real at tiny sizes on the CPU (on a node they run with CUDA): rvn-rl's run with
    the plan's 4 envs in 2 workers of 2 instead of 4 of 1 (row rl_workers_2, its label and settings naming them),
    then the envs alone in each layout of 2-6 envs a worker (2 x 2, 1 x 4); the ladder's base takes the faster run's
    workers."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    from types import SimpleNamespace

    import node as node_bench
    import node_rl
    import node_rl_ladder

    plan = node_bench.make_plan(node_bench.parse(["--quick"]), False, 2)
    plan = SimpleNamespace(**{**vars(plan), "rl_envs": 4, "rl_workers": 4, "rl_scenes": 2})
    small = dict(size=plan.rl_size, backbone="resnet18", num_steps=plan.rl_num_steps, ppo_epoch=1, mini_batches=1)
    kept = str(tmp_path / "cache")
    plan = SimpleNamespace(**vars(plan), rl_cache=kept, rl_filled=node_rl.fill_scene_caches(plan, small, kept))
    gen = node_rl_ladder.layout_rows(plan, small, {"key": "rl", "value": 1e-6})
    rows = []
    try:
        while True:
            rows.append(next(gen))
    except StopIteration as stop:
        base = stop.value
    assert [r["key"] for r in rows] == ["rl_workers_2", "rl_envs_2x2", "rl_envs_1x4"]
    assert all(r["value"] > 0 and not r["error"] for r in rows), rows
    assert "env.workers=2" in rows[0]["label"] and "x 4 envs, 1 epochs x 1 mini-batches, 2 env worker processes" in \
        rows[0]["settings"], rows[0]
    assert "4 envs in 1 worker processes" in rows[2]["settings"], rows[2]
    assert base == {**small, "workers": 2}  # faster than the 1e-6 env steps/s given as the rl row's


@pytest.mark.slow
def test_env_phases_benchmark_splits_the_envs_step_by_process_count(tmp_path):
    """benchmarks/rl_env_phases.py (what bounds rvn-rl's envs side by side) at a tiny size: the cache root filled, then
    one and two processes of 2 envs each, each line with the rate together and a process's, and the phases' ms; the
    two also through rvn-rl's worker processes."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "rl_env_phases.py"), "--processes", "1", "2",
                           "--envs", "2", "--seconds", "0.5", "--warm", "0", "--scenes", "2", "--size", "64",
                           "--renderer", "raycast"], capture_output=True, text=True, timeout=600)
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
    # Habitat's scene switches (env.scene_switch_steps): none within a short run, and resets are not counted as switches
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "rl_env_phases.py"), "--processes", "1",
                           "--envs", "2", "--seconds", "0.5", "--warm", "0", "--scenes", "2", "--size", "64",
                           "--renderer", "raycast", "--scene-switch-steps", "100000"], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "a scene switch at the first reset after ~100000 steps in one" in proc.stdout, proc.stdout
    assert "scene switches in 0.0% of the steps: 0.00 ms a step" in proc.stdout, proc.stdout


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
