"""CPU threads of worker processes (issue 32, `rvn_data.worker_threads`): rvn-gen's workers start with one
thread each, rvn-eval's and rvn-rl's with their share of the cores (cores // workers), in the variables the
libraries read when they load; a variable the user set wins; OpenCV takes the share and torch
OMP_NUM_THREADS's count; the parent's environment is as before. What a worker saw is written by tests/thread_probe/sitecustomize.py (every
Python process on its PYTHONPATH records the variables it started with) and, in rvn-eval, reported by
tests/thread_probe/thread_probe_policy.py through the episode records."""
from __future__ import annotations

import json
import multiprocessing as mp
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rvn_data.benchmark.metrics import read_records
from rvn_data.worker_threads import THREAD_VARS, settle_worker_threads, worker_threads

PROBE = Path(__file__).resolve().parent / "thread_probe"
SHARE_OF_2 = max(1, len(os.sched_getaffinity(0)) // 2)  # each of 2 workers' share of this machine's cores


def probed_env(folder: Path, **user: str) -> dict:
    """This environment without the thread variables (but ``user``'s), with the probe writing to ``folder``."""
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARS}
    path = os.pathsep.join(p for p in (str(PROBE), env.get("PYTHONPATH")) if p)
    return {**env, **user, "PYTHONPATH": path, "RVN_THREAD_PROBE": str(folder)}


def worker_starts(folder: Path) -> dict[str, dict]:
    """The variables each multiprocessing worker (by pid) started with, as the probe wrote them."""
    runs = {p.name.split(".")[0]: json.loads(p.read_text()) for p in folder.glob("*.start.json")}
    return {pid: r["env"] for pid, r in sorted(runs.items()) if "--multiprocessing-fork" in r["cmd"]}


def test_worker_threads_sets_what_the_user_did_not_and_restores_the_environment(monkeypatch):
    for k in THREAD_VARS:
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    before = dict(os.environ)
    with worker_threads(2):
        assert {k: os.environ[k] for k in THREAD_VARS} == {
            "LP_NUM_THREADS": "2", "OMP_NUM_THREADS": "3", "OPENBLAS_NUM_THREADS": "2", "MKL_NUM_THREADS": "2",
            "TORCHINDUCTOR_COMPILE_THREADS": "2"}
    with worker_threads(1):  # a pool of one compiles in the worker itself, slower: at least two
        assert os.environ["TORCHINDUCTOR_COMPILE_THREADS"] == "2" and os.environ["LP_NUM_THREADS"] == "1"
    assert dict(os.environ) == before
    with pytest.raises(RuntimeError), worker_threads(1):  # restored when starting the workers fails too
        raise RuntimeError("no workers")
    assert dict(os.environ) == before
    with pytest.raises(ValueError, match="worker threads=0 must be a positive integer"):
        with worker_threads(0):
            pass


def _settled(threads: int, out) -> None:
    import cv2
    import torch
    from torch._inductor import config

    torch.set_num_threads(5)  # loaded (and set) before the worker settles its threads
    settle_worker_threads(threads)
    out.put((cv2.getNumThreads(), torch.get_num_threads(), config.compile_threads,
             {k: os.environ[k] for k in THREAD_VARS}))


@pytest.mark.slow
@pytest.mark.parametrize("user", [{}, {"OMP_NUM_THREADS": "3"}])
def test_a_worker_settles_opencv_and_a_loaded_torch(monkeypatch, user):
    """A process not started inside `worker_threads` gets the variables too; OpenCV its share, and torch
    OMP_NUM_THREADS's count, the user's when set (as torch reads it when it loads); torch.compile's pool too."""
    for k in THREAD_VARS:
        monkeypatch.delenv(k, raising=False)
    for k, v in user.items():
        monkeypatch.setenv(k, v)
    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    p = ctx.Process(target=_settled, args=(1, out))
    p.start()
    cv2_threads, torch_threads, compile_threads, env = out.get(timeout=120)
    p.join(timeout=30)
    assert (cv2_threads, torch_threads, compile_threads) == (1, 3 if user else 1, 2)
    assert env == {**dict.fromkeys(THREAD_VARS, "1"), "TORCHINDUCTOR_COMPILE_THREADS": "2", **user}


@pytest.mark.slow
def test_rvn_gen_workers_start_with_one_thread_each_unless_the_user_says(tmp_path):
    probe = tmp_path / "probe"
    probe.mkdir()
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={tmp_path / 'out'}", "workers=2",
                           "scenes.num_scenes=2", "trajectories_per_scene=1", "camera.width=32", "camera.height=32",
                           "progress=false"], capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env=probed_env(probe, OMP_NUM_THREADS="3"))
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    one = {"LP_NUM_THREADS": "1", "OMP_NUM_THREADS": "3", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "TORCHINDUCTOR_COMPILE_THREADS": "2"}
    assert list(worker_starts(probe).values()) == [one, one]


@pytest.mark.slow
def test_rvn_eval_workers_get_their_share_of_the_cores(tmp_path):
    """Both of rvn-eval's pools: the one that builds the episode sets and the one that runs the episodes,
    whose policies see OpenCV and torch with the same share."""
    probe = tmp_path / "probe"
    probe.mkdir()
    proc = subprocess.run([sys.executable, "-m", "rvn_data.benchmark.cli", "split=val", "episodes.num_scenes=2",
                           "episodes.per_scene=1", "episodes.n_goals=3", "camera.width=32", "camera.height=32",
                           f"episodes.dir={tmp_path / 'episodes'}", f"out_dir={tmp_path / 'out'}", "workers=2",
                           "policy=random", "policy._target_=thread_probe_policy.ThreadProbePolicy", "progress=false"],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path, env=probed_env(probe))
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    share = {**dict.fromkeys(THREAD_VARS, str(SHARE_OF_2)), "TORCHINDUCTOR_COMPILE_THREADS": str(max(2, SHARE_OF_2))}
    assert list(worker_starts(probe).values()) == [share] * 4
    records = read_records(tmp_path / "out" / "episodes.jsonl")
    assert [r["policy_stats"] for r in records] == [{"cv2_threads": SHARE_OF_2, "torch_threads": SHARE_OF_2,
                                                     "compile_threads": max(2, SHARE_OF_2)}] * 2  # policy.compile's


@pytest.mark.slow
def test_rl_env_workers_get_their_share_and_the_parent_keeps_its_environment(tmp_path, monkeypatch):
    from rvn_rl.vec_procs import ProcessBatchEnv

    for k in THREAD_VARS:
        monkeypatch.delenv(k, raising=False)
    for k in ("OMP_NUM_THREADS", "PYTHONPATH", "RVN_THREAD_PROBE"):
        monkeypatch.setenv(k, probed_env(tmp_path, OMP_NUM_THREADS="3")[k])
    before = dict(os.environ)
    kw = dict(mode="train", split="train", scenes={"num_scenes": 2}, camera={"width": 32, "height": 32},
              renderer={"backend": "raycast"}, episodes={"n_goals": 2})
    envs = ProcessBatchEnv(kw, 2, workers=2)
    try:
        assert dict(os.environ) == before
        envs.reset()
    finally:
        envs.close()
    share = {**dict.fromkeys(THREAD_VARS, str(SHARE_OF_2)), "OMP_NUM_THREADS": "3",
             "TORCHINDUCTOR_COMPILE_THREADS": str(max(2, SHARE_OF_2))}
    workers = worker_starts(tmp_path)
    assert list(workers.values()) == [share, share]
    ends = [json.loads((tmp_path / f"{pid}.exit.json").read_text()) for pid in workers]
    assert [e["cv2"] for e in ends] == [SHARE_OF_2] * 2  # OpenCV: the share (OMP_NUM_THREADS is not its)
