"""The node's CPUs, for benchmarks/node.py's header: the model, the cgroup's CPU quota, the load average, and how
a CPU-bound Python + numpy loop scales when every CPU runs one side by side (`scaling`).

Why: on both GPU runs (2026-11-27) rvn-gen's and rvn-rl's workers were about 3.5x slower per process in 15-16
processes on the node than in 1-2 on the 2-core development CPU, and the compiled training steps were bound by the
host. Whether that is the node's cores (slower, shared, hyperthreads, a quota below the CPU count) or RVN's code,
this probe says in a few seconds: the loop's rate alone is comparable across machines, and its rate per process
with all CPUs busy, divided by that, is the share of a core a worker gets.
On the 2-core development machine (AMD EPYC): about 360 k loops/s alone, x0.97 with 2 side by side."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

# each child waits until START, runs the loop until START + SECONDS, then prints how many loops it ran
_CHILD = """
import sys, time
import numpy as np
start, seconds = float(sys.argv[1]), float(sys.argv[2])
a, n = np.arange(64, dtype=np.float64), 0
while time.monotonic() < start:
    time.sleep(0.001)
while time.monotonic() < start + seconds:
    for _ in range(50):
        a = np.sqrt(a * a + 1.0) - 0.5
        s = float(a.sum())
    n += 50
print(n / seconds)
"""


def loop_rates(processes: int, seconds: float, start_delay: float = 1.0) -> list[float]:
    """Loops/s of each of ``processes`` children running the loop over the same ``seconds`` (monotonic clock,
    shared by the processes on Linux), after all have started."""
    start = time.monotonic() + start_delay + 0.05 * processes
    procs = [subprocess.Popen([sys.executable, "-c", _CHILD, repr(start), repr(seconds)], stdout=subprocess.PIPE,
                              text=True) for _ in range(processes)]
    try:
        rates = []
        for p in procs:
            out, _ = p.communicate(timeout=start_delay + 0.05 * processes + seconds + 60)
            if p.returncode != 0:
                raise RuntimeError(f"the CPU probe's loop exited with status {p.returncode}")
            rates.append(float(out.strip()))
        return rates
    finally:  # none left running when one failed
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()


def scaling(processes: int, seconds: float) -> dict:
    """The loop alone, then in ``processes`` processes side by side: rates in loops/s and their ratio."""
    alone = loop_rates(1, seconds)[0]
    side = loop_rates(processes, seconds) if processes > 1 else [alone]
    mean = sum(side) / len(side)
    return {"processes": processes, "seconds": seconds, "alone": alone, "side_by_side": mean,
            "slowest": min(side), "ratio": mean / alone}


def cpu_quota(root: Path = Path("/sys/fs/cgroup")) -> float | None:
    """CPUs' worth of time the cgroup allows (cgroup v2 ``cpu.max``, else v1's CFS quota), None without a limit."""
    try:
        quota, period = (root / "cpu.max").read_text().split()[:2]
        return None if quota == "max" else int(quota) / int(period)
    except (OSError, ValueError):
        pass
    try:
        quota = int((root / "cpu" / "cpu.cfs_quota_us").read_text())
        period = int((root / "cpu" / "cpu.cfs_period_us").read_text())
        return None if quota <= 0 else quota / period
    except (OSError, ValueError):
        return None


def cpu_model() -> str:
    """The first ``model name`` of /proc/cpuinfo ("unknown" where there is none)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def cpu_info(processes: int, seconds: float) -> dict:
    """What the header says about the CPUs: model, quota, 1-minute load average before the probe, the probe."""
    return {"model": cpu_model(), "quota": cpu_quota(), "load_1min": os.getloadavg()[0],
            "scaling": scaling(processes, seconds)}


def describe(cpu: dict, cpus: int) -> str:
    """One line of node.md's header."""
    if "error" in cpu:
        return f"CPUs: the probe FAILED ({cpu['error'][:200]})"
    s = cpu["scaling"]
    quota = "none" if cpu["quota"] is None else f"{cpu['quota']:g} CPUs"
    return (f"CPUs: {cpu['model']}; cgroup CPU quota: {quota}; load average {cpu['load_1min']:.1f} at the start; "
            f"a Python + numpy loop (node_cpu.py) ran {s['alone'] / 1e3:.1f} k loops/s alone and "
            f"x{s['ratio']:.2f} of that per process with {s['processes']} side by side (slowest "
            f"x{s['slowest'] / s['alone']:.2f}; of {cpus} CPUs)")
