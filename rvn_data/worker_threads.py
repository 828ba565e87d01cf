"""How many CPU threads each worker process uses: one rule for every process pool (rvn-gen's scenes,
rvn-eval's episodes and episode sets, rvn-rl's env workers).

Mesa's software GL (llvmpipe), OpenMP, OpenBLAS, MKL, OpenCV and torch each start a thread per core in
every process by default; with one worker per core that is cores x cores threads, and BLAS pools that
spin while they wait make small numpy/scipy calls many times slower (issue 32: 16 ms against 0.7 ms
per planned frame on a 16-core node). The libraries read their variables when they load, before a
worker's own code runs, so the parent sets them while it starts the workers (`worker_threads`); a
worker then calls `settle_worker_threads` first thing for what has no variable (OpenCV) or was
loaded before it ran (torch). A variable the user set is left as it is, in the workers too.

torch.compile's code generation (``policy.compile`` in rvn-eval's workers) starts a pool of compile processes, one
per core by default, in every process that compiles: N workers compiling at once would start N x cores of them
(~16 x 16 on a 16-core node, ~0.1 GB each). TORCHINDUCTOR_COMPILE_THREADS gives each worker its share instead, at
least `MIN_COMPILE_THREADS` (`compile_threads`).
"""
from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

COMPILE_VAR = "TORCHINDUCTOR_COMPILE_THREADS"
THREAD_VARS = ("LP_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", COMPILE_VAR)
# a pool of one compiles in the worker itself, with nothing beside its single-threaded tracing: two rvn-eval workers
# compiling NoMaD at once on 2 cores took 126 and 117 s so, 110 and 92 s with a pool of two each (two runs of
# benchmarks/compile_pool.py)
MIN_COMPILE_THREADS = 2


def compile_threads(threads: int) -> int:
    """The compile processes of torch.compile's pool in a process whose share of the cores is ``threads``."""
    return max(MIN_COMPILE_THREADS, threads)


def _value(var: str, threads: int) -> str:
    return str(compile_threads(threads) if var == COMPILE_VAR else threads)


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity: a batch job's share of a node), else all."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # no affinity on this platform
        return os.cpu_count() or 1


def threads_per_worker(workers: int) -> int:
    """Each of ``workers`` processes' share of the usable cores, at least 1."""
    return max(1, usable_cores() // max(1, int(workers)))


@contextmanager
def environ(env: dict | None) -> Iterator[None]:
    """``env`` set in this process's environment (and so in the workers it starts) while the block runs; afterwards
    each variable as it was (unset where it was unset)."""
    old = {k: os.environ.get(k) for k in env or {}}
    os.environ.update(env or {})
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextmanager
def worker_threads(threads: int) -> Iterator[None]:
    """In the parent, around starting worker processes (they inherit its environment): the variables of
    `THREAD_VARS` the user has not set hold ``threads`` (TORCHINDUCTOR_COMPILE_THREADS `compile_threads`'s count for
    it); afterwards the parent's environment is as before."""
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"worker threads={threads!r} must be a positive integer")
    unset = [k for k in THREAD_VARS if k not in os.environ]
    os.environ.update({k: _value(k, threads) for k in unset})
    try:
        yield
    finally:
        for k in unset:
            os.environ.pop(k, None)


def settle_worker_threads(threads: int) -> None:
    """In a worker, first thing: the variables the parent did not pass set to ``threads`` (a process not
    started inside `worker_threads`; software GL reads LP_NUM_THREADS when it makes its context); OpenCV
    uses ``threads`` (it reads no variable of these) and torch, only if already imported (this does not
    import it), OMP_NUM_THREADS's count, as it does itself when it loads later; so does torch.compile's
    compile pool with TORCHINDUCTOR_COMPILE_THREADS's."""
    for k in THREAD_VARS:
        os.environ.setdefault(k, _value(k, threads))
    import cv2

    cv2.setNumThreads(threads)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(_positive(os.environ["OMP_NUM_THREADS"]) or threads)
    inductor = sys.modules.get("torch._inductor.config")
    if inductor is not None:  # read from the variable when it loaded
        inductor.compile_threads = _positive(os.environ[COMPILE_VAR]) or compile_threads(threads)


def _positive(text: str) -> int | None:
    try:
        n = int(text)
    except ValueError:
        return None
    return n if n > 0 else None


__all__ = ["COMPILE_VAR", "THREAD_VARS", "compile_threads", "settle_worker_threads", "threads_per_worker",
           "usable_cores", "worker_threads"]
