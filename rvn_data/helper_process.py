"""Work in a process of its own, for a thread that prepares something while its process steps envs (rvn-rl's
``env.prefetch_scenes``: the next scene, its navmesh and goal pool).

A thread that prepares a scene in an env's process takes turns with the env's steps for the GIL: loading a
procedural scene took 0.9 s (median) there against 0.05-0.1 s alone, and scipy's Dijkstra (a goal pool's 64 solves)
holds the GIL throughout, stalling the steps (2-core development CPU, 2 envs in one process, 200 scenes; since
2026-11-28 the solves, and now the whole preparation, run here). The thread then only waits for the answer.

`HelperProcess.call(fn, *args)` runs ``fn(*args)`` in the helper and returns its result; an exception raised there
is raised here. ``fn`` is a module-level function (pickled by name; its module is imported in the helper), its
arguments and result picklable. The process is started on first use with `subprocess` (a daemonic env worker may
start it; multiprocessing would refuse) and runs this module's `main`; it ends when its input closes (`close`, or its
parent's exit), and starts again at the next call if it died.
"""
from __future__ import annotations

import os
import pickle
import subprocess
import sys
import threading
from pathlib import Path


class HelperProcess:
    """One helper process, its calls one at a time (a lock: one per env is the intended use)."""

    def __init__(self):
        self._proc: subprocess.Popen | None = None
        self._lock = threading.Lock()

    def call(self, fn, *args):
        """``fn(*args)`` run in the helper process: its result, or its exception raised here."""
        request = pickle.dumps((fn, args), protocol=pickle.HIGHEST_PROTOCOL)  # what does not pickle fails here, whole
        with self._lock:
            proc = self._start()
            try:
                proc.stdin.write(request)
                proc.stdin.flush()
                ok, value = pickle.load(proc.stdout)
            except (OSError, EOFError, pickle.UnpicklingError) as err:
                self._stop()
                raise RuntimeError(f"the helper process (rvn_data.helper_process) failed in {fn.__qualname__}: "
                                   f"{err!r}; its error, if it printed one, is above. Set env.prefetch_scenes=false "
                                   "to prepare scenes in the env's own process") from err
        if not ok:
            raise value
        return value

    def _start(self) -> subprocess.Popen:
        if self._proc is not None and self._proc.poll() is not None:  # ended since the last call: its pipes closed
            self._stop()
        if self._proc is None:
            root = str(Path(__file__).resolve().parents[1])  # this checkout's rvn_data, installed or not
            path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH", "")) if p)
            self._proc = subprocess.Popen([sys.executable, "-m", "rvn_data.helper_process"],
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                          env={**os.environ, "PYTHONPATH": path})
            _widen(self._proc.stdin, self._proc.stdout)
        return self._proc

    def _stop(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        for pipe in (proc.stdin, proc.stdout):
            try:
                pipe.close()
            except OSError:
                pass
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()

    def close(self) -> None:
        """End the process (it exits at the end of its input)."""
        with self._lock:
            self._stop()


def _widen(*pipes) -> None:
    """Pipes of up to 1 MiB (Linux; 64 KiB by default): an answer of a few MB then crosses in a few writes instead of
    ~100, and each write is a point where the waiting thread gives up the GIL and waits ~5 ms (the switch interval) to
    get it back from the env's steps."""
    import fcntl

    for pipe in pipes:
        try:
            fcntl.fcntl(pipe.fileno(), fcntl.F_SETPIPE_SZ, 1 << 20)
        except (AttributeError, OSError):  # not Linux, or a lower limit (fs.pipe-max-size): the default size
            pass


def main() -> None:
    """The helper's loop: a call (function, arguments) in, (True, its result) or (False, its exception) out, until
    its input ends."""
    source, sink = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # what the functions print goes to the parent's stderr, not into the answers' pipe
    while True:
        try:
            fn, args = pickle.load(source)
        except EOFError:
            return
        try:
            answer = pickle.dumps((True, fn(*args)), protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as err:  # raised in the caller's process
            try:
                answer = pickle.dumps((False, err), protocol=pickle.HIGHEST_PROTOCOL)
            except Exception:  # an exception that does not pickle: its text
                answer = pickle.dumps((False, RuntimeError(f"{type(err).__name__}: {err}")))
        sink.write(answer)
        sink.flush()


if __name__ == "__main__":
    main()
