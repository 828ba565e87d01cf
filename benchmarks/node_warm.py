"""node.py --warm: the compiled rows' cold compiles, done together in parallel processes before any row is timed;
and (always) RVN's numba kernels, compiled once in node.py's process before the rows whose workers run them
(`numba_kernels`).

A cold ``torch.compile`` of NoMaD full's training step, ViNT's, NoMaD's whole sampling on the GPU and on the CPU
each take minutes (the first GPU run's time limits cut two of them). Each job here runs in a process of its own, at
the sizes node.py's rows use (`node.make_plan`), until its first compiled steps are done, which fills inductor's
kernel cache (the cache root's ``compiled`` folder, or ``TORCHINDUCTOR_CACHE_DIR``). The rows that follow, timed
one at a time as before, then load the kernels instead of generating them: each still traces its model (dynamo
and AOT autograd), but the code generation and kernel compiles, most of a cold compile, run once and side by side.
No figure is taken here; the rows' figures are after their own warm-up, as without --warm.

    python benchmarks/node_warm.py JOB PLAN_JSON   (one job, as node.py starts it)
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

HERE = Path(__file__).resolve().parent


def jobs(plan, groups: list[str]) -> list[str]:
    """The compiled rows' jobs of the row ``groups`` (none without ``plan.compile``)."""
    if not plan.compile:
        return []
    out = []
    if "train" in groups:  # a job per torch.compile mode (node.py --compile-mode): "<row>" or "<row>@<mode>"
        out += [f"train_{m}" + ("" if mode == "default" else f"@{mode}")
                for mode in plan.compile_modes for m in ("nomad_pointgoal", "vint_pointgoal")]
    if "decision" in groups:
        out += (["decision_gpu"] if plan.cuda else []) + ["decision_cpu"]
    return out


def warm(plan, groups: list[str], timeout: float) -> list[str]:
    """Runs the jobs of ``groups`` side by side, each at most ``timeout`` seconds; one line per job (when it ended,
    or why it stopped). A job that fails or runs out of time only leaves its row a cold compile."""
    todo = jobs(plan, groups)
    if not todo:
        return []
    spec = json.dumps(vars(plan))
    with tempfile.TemporaryDirectory() as logs:  # stderr to files: a full pipe would stall a job nobody reads yet
        t0, procs, ended = time.perf_counter(), {}, {}
        for j in todo:  # each in a session of its own: a stopped job takes its compile workers and compilers along
            with open(Path(logs) / j, "w") as err:
                procs[j] = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), j, spec],
                                            stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
        while len(ended) < len(procs) and time.perf_counter() - t0 < timeout:
            ended |= {j: time.perf_counter() - t0 for j, p in procs.items() if j not in ended and p.poll() is not None}
            time.sleep(0.2)
        lines = []
        for j, p in procs.items():
            if j not in ended and p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
                lines.append(f"{j}: stopped after {timeout:.0f} s (its row compiles the rest)")
                continue
            last = (Path(logs) / j).read_text().strip().splitlines()[-1:] or [""]
            lines.append(f"{j}: {ended.get(j, time.perf_counter() - t0):.0f} s" + ("" if p.returncode == 0 else
                                                                 f", FAILED ({last[0][:200]})"))
    return lines


NUMBA_GROUPS = ("render", "gen", "rl")  # the rows whose processes run RVN's numba kernels (navmesh, planning, ray casting)


def numba_kernels(groups: list[str]) -> str | None:
    """RVN's numba kernels compiled (or loaded) here, once, before the rows of ``groups`` that run them in worker
    processes; the header's line, or None when no such row runs. numba caches its kernels per install
    (`rvn_data.numba_note`, beside the modules in ``__pycache__``), and a GPU lease starts without them (the checkout
    travels without ignored files): there, each worker process of the first such row would compile them at once,
    inside its first update or trajectories, and rvn-gen's sizing run, whose one-process figures stand beside the
    workers', would compile them inside its phases. Cold, this takes about 25 s on the 2-core
    development CPU (a one-trajectory rvn-gen: set-up 59%, planning 37%); cached, about 2 s
    (`rvn_data.warm_kernels.warm_kernels`)."""
    if not set(groups) & set(NUMBA_GROUPS):
        return None
    from rvn_data.numba_note import kernels_cached
    from rvn_data.warm_kernels import warm_kernels

    cached, t = kernels_cached(), time.perf_counter()
    warm_kernels()
    return (f"numba kernels {'loaded from the cache' if cached else 'compiled (a fresh install)'} in "
            f"{time.perf_counter() - t:.0f} s, before the rows")


def run_job(job: str, plan) -> None:
    """One job: the compiled path of one row, at its sizes, through its first steps."""
    sys.path.insert(0, str(HERE))
    import decision as decision_bench
    import train as train_bench
    from node_rows import decision_sizes, train_settings, write_train_data
    from rvn_il.models import load_model_config

    if job.startswith("decision_"):
        where = job.removeprefix("decision_")
        decision_bench.decision_ms("nomad_pointgoal", decision_sizes(plan)[where], 1, threads=1, reference=False,
                                   device="cuda" if where == "gpu" else "cpu", compile=True)
        return
    from rvn_il.policies.policy import intra_op_threads

    name, _, mode = job.removeprefix("train_").partition("@")
    device, size, precision = train_settings(plan)
    with tempfile.TemporaryDirectory() as tmp:
        root = write_train_data(plan, Path(tmp))
        with intra_op_threads(plan.train_threads):  # as the row: inductor's CPU kernels are made for a thread count
            train_bench.steady_train_rate(root, load_model_config(name, size), plan.train_batch, 0.1, device,
                                          precision, min(2, plan.loader_workers), str(Path(tmp) / "cache"), True,
                                          compile_mode=mode or "default")


if __name__ == "__main__":
    run_job(sys.argv[1], SimpleNamespace(**json.loads(sys.argv[2])))
