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
