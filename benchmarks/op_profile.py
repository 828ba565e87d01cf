"""torch.profiler's operator table of a few steady-state steps (benchmarks/node.py --profile): where a training
step's or a decision's time goes, by operator, on the CPU and, with CUDA, on the GPU (issue 32: "the profile
decides"). ``loader wait`` and ``policy.act`` mark the parts that are not one operator."""
from __future__ import annotations

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
    if cuda:  # where the GPU waits for the host: what the host spends its time on, and where it waits for the GPU
        waits = [f"{e.key} x{e.count} ({e.self_cpu_time_total / 1e3:.1f} ms)" for e in events if e.key in HOST_WAITS]
        text += (f"\nhost waits for the GPU: {', '.join(waits) or 'none'}\n\nby self CPU time (the host's side):\n"
                 + events.table(sort_by="self_cpu_time_total", row_limit=rows, max_name_column_width=60))
    return text


# the host blocks in these until the GPU catches up (a .item(), a pageable copy, an explicit synchronize)
HOST_WAITS = ("cudaStreamSynchronize", "cudaDeviceSynchronize", "cudaEventSynchronize", "cudaMemcpy",
              "aten::_local_scalar_dense", "aten::item")
