"""Dijkstra solves in a process of their own, for a thread that prepares a scene while its process steps envs
(rvn-rl's ``env.prefetch_scenes``: the next scene's goal pool).

scipy's ``dijkstra`` holds the GIL while it solves. A goal pool's 64 solves (0.2-0.5 s on a procedural apartment)
in a thread therefore took turns with the env's own steps: each step waited for them, and the pool took two to
three times its CPU time (2-core development CPU: 0.5-1.5 s), often more than the scene's episodes lasted, so the
switch still waited. Here they run in another process while the env steps.

`SolverProcess.predecessors(graph, nodes)` gives what ``dijkstra(graph, directed=True, indices=nodes,
return_predecessors=True)[1]`` gives in this process (the same trees: tests/test_env.py). The process is started on
first use with `subprocess` (a daemonic env worker may start it; multiprocessing would refuse) and runs this module's
`main`; it ends when its input closes (`close`, or its parent's exit). Requests and answers are pickled over its
pipes: the graph's CSR arrays (~9 MB for a procedural apartment's ~700k edges) and the predecessors (4 bytes a node
and goal).
"""
from __future__ import annotations

import os
import pickle
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np


class SolverProcess:
    """One helper process, its requests one at a time (a lock: one per env is the intended use)."""

    def __init__(self):
        self._proc: subprocess.Popen | None = None
        self._lock = threading.Lock()

    def predecessors(self, graph, nodes) -> np.ndarray:
        """Predecessor trees int32 [len(nodes), graph nodes] of the shortest paths from each of ``nodes``."""
        request = (graph.indptr, graph.indices, graph.data, graph.shape[0], np.asarray(nodes, np.int64))
        with self._lock:
            proc = self._start()
            try:
                pickle.dump(request, proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
                proc.stdin.flush()
                pred = pickle.load(proc.stdout)
            except (OSError, EOFError, pickle.UnpicklingError) as err:
                self._stop()
                raise RuntimeError(f"the Dijkstra helper process (rvn_data.navmesh.solver_process) failed: {err!r}; "
                                   "its error, if it printed one, is above. Set env.prefetch_scenes=false to "
                                   "solve in the env's own process") from err
        return pred

    def _start(self) -> subprocess.Popen:
        if self._proc is not None and self._proc.poll() is not None:  # ended since the last request: its pipes closed
            self._stop()
        if self._proc is None:
            root = str(Path(__file__).resolve().parents[2])  # this checkout's rvn_data, installed or not
            path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH", "")) if p)
            self._proc = subprocess.Popen([sys.executable, "-m", "rvn_data.navmesh.solver_process"],
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
    """Pipes of up to 1 MiB (Linux; 64 KiB by default): a request's ~9 MB then crosses in ~9 writes instead of ~140,
    and each write is a point where the preparing thread gives up the GIL and waits ~5 ms (the switch interval) to
    get it back from the env's steps."""
    import fcntl

    for pipe in pipes:
        try:
            fcntl.fcntl(pipe.fileno(), fcntl.F_SETPIPE_SZ, 1 << 20)
        except (AttributeError, OSError):  # not Linux, or a lower limit (fs.pipe-max-size): the default size
            pass


def main() -> None:
    """The helper's loop: a request (CSR arrays, node count, sources) in, the predecessors out, until its input ends."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    source, sink = sys.stdin.buffer, sys.stdout.buffer
    while True:
        try:
            indptr, indices, data, n, nodes = pickle.load(source)
        except EOFError:
            return
        graph = csr_matrix((data, indices, indptr), shape=(n, n))
        pred = dijkstra(graph, directed=True, indices=nodes, return_predecessors=True)[1]
        pickle.dump(pred, sink, protocol=pickle.HIGHEST_PROTOCOL)
        sink.flush()


if __name__ == "__main__":
    main()
