"""torch.profiler's operator table of a few steady-state steps (benchmarks/node.py --profile): where a training
step's or a decision's time goes, by operator, on the CPU and, with CUDA, on the GPU (issue 32: "the profile
decides"). ``loader wait``, ``policy.act`` and the training step's phases (`phase`: ``step: forward``...) mark
the parts that are not one operator; the table ends with the host's time per phase and a Python-level profile
(cProfile) of the same steps run once more, which names the Python functions the host spends its time in."""
from __future__ import annotations

import cProfile
import io
import pstats
import sys
import time
from typing import Callable

import torch

ROWS = 30  # operators listed, by self time on the device that does the work


def op_table(run: Callable[[], None], cuda: bool, rows: int = ROWS) -> str:
    """The operator table of ``run()`` (CPU time, and GPU time with ``cuda``; the GPU is synchronised before
    the profile ends), sorted by self GPU time with ``cuda``, else by self CPU time. With ``cuda`` also the
    host's side: the calls in which it waited for the GPU (`HOST_WAITS`) and the table by self CPU time (the
    second GPU run's compiled training steps ran a third of their wall time in kernels: bound on the host)."""
    from torch.profiler import ProfilerActivity, profile

    activities = [ProfilerActivity.CPU] + ([ProfilerActivity.CUDA] if cuda else [])
    sync = torch.cuda.synchronize if cuda else (lambda: None)
    sync()
    with profile(activities=activities) as prof:
        t = time.perf_counter()
        run()
        sync()
        wall = time.perf_counter() - t
    events = prof.key_averages()
    table = events.table(sort_by="self_cuda_time_total" if cuda else "self_cpu_time_total", row_limit=rows,
                         max_name_column_width=60)
    # the GPU's busy share of these steps: the table's "Self CUDA time total" over this wall time
    text = f"wall time of the profiled run, under the profiler: {1e3 * wall:.1f} ms\n{table}"
    phases = phase_times(prof.events())
    if phases:
        text += ("\nhost time per phase (ms a call, children included): "
                 + ", ".join(f"{k} {v:.1f}" for k, v in phases.items()) + "\n")
    if cuda:  # where the GPU waits for the host: what the host spends its time on, and where it waits for the GPU
        waits = [f"{e.key} x{e.count} ({e.self_cpu_time_total / 1e3:.1f} ms)" for e in events if e.key in HOST_WAITS]
        text += (f"\nhost waits for the GPU: {', '.join(waits) or 'none'}\n\nby self CPU time (the host's side):\n"
                 + events.table(sort_by="self_cpu_time_total", row_limit=rows, max_name_column_width=60))
    return text + "\n" + python_table(run, rows)


PHASE = "step: "


def phase(name: str):
    """A part of a step for the profiles (``step: <name>``): its host time is listed per call."""
    return torch.profiler.record_function(PHASE + name)


def phase_times(events) -> dict[str, float]:
    """Mean host ms per call of each `phase` among the profiler's ``events``, in the order first seen (the CPU's
    events only: on CUDA a phase is also a GPU annotation of the same name)."""
    from torch.autograd import DeviceType

    times: dict[str, list[float]] = {}
    for e in events:
        if e.name.startswith(PHASE) and e.device_type == DeviceType.CPU:
            times.setdefault(e.name[len(PHASE):], []).append(e.cpu_time_total / 1e3)
    return {k: sum(v) / len(v) for k, v in times.items()}


def python_table(run: Callable[[], None], rows: int = ROWS) -> str:
    """cProfile of ``run()`` (once more), by own time: the Python functions and the C functions they call on this
    thread. On CUDA autograd runs a backward in a thread of its own: it shows as ``run_backward``."""
    prof = cProfile.Profile()
    prof.enable()
    try:
        run()
    finally:
        prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(rows)
    body = out.getvalue()
    body = body[body.find("   ncalls"):] if "   ncalls" in body else body  # without pstats' preamble
    for prefix in sorted({p for p in sys.path if len(p) > 1}, key=len, reverse=True):  # module paths, not files'
        body = body.replace(prefix + "/", "")
    return f"by Python function (cProfile of the same steps run once more, own time):\n{body.rstrip()}\n"


# the host blocks in these until the GPU catches up (a .item(), a pageable copy, an explicit synchronize)
HOST_WAITS = ("cudaStreamSynchronize", "cudaDeviceSynchronize", "cudaEventSynchronize", "cudaMemcpy",
              "aten::_local_scalar_dense", "aten::item")
