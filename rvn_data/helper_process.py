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

An answer's large arrays (pickle protocol 5's out-of-band buffers, `SHARED_BYTES` or more in all) cross in a file in
shared memory (``/dev/shm``, else the temp folder), which the caller reads in one call (the GIL released throughout)
and deletes at once, and only the rest through the pipe: a 25 MB answer (a scene's is 14-26 MB: navmesh, graph,
goal pool, mesh) took 308 ms to read through the pipe in a thread while the process's own thread ran Python (58 ms
alone), 1 MB of pipe a time, each a wait for the GIL; 65 ms so. An RL env's scene preparation (one process, 2 envs,
2-core development CPU) took 380-478 ms (90th percentile 558-607 ms) against 477-485 (733-745) through the pipe. A
file that cannot be written (a full /dev/shm) sends the answer through the pipe; one the caller never took (it died)
is deleted by the helper at its next answer or exit; the caller chooses the folder (`HelperProcess.shared_folder`).
"""
from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

SHARED_BYTES = 1 << 20  # an answer's out-of-band buffers of at least this many bytes cross in shared memory
_ALIGN = 64  # each buffer's offset in the file: numpy's arrays stay aligned


class HelperProcess:
    """One helper process, its calls one at a time (a lock: one per env is the intended use)."""

    def __init__(self, shared_folder: str | None = None):
        self._proc: subprocess.Popen | None = None
        self._lock = threading.Lock()
        self.shared_folder = shared_folder or _shared_folder()  # where large answers cross (module docstring)

    def call(self, fn, *args):
        """``fn(*args)`` run in the helper process: its result, or its exception raised here."""
        # what does not pickle fails here, whole; the folder: where the helper puts a large answer
        request = pickle.dumps((fn, args, self.shared_folder), protocol=pickle.HIGHEST_PROTOCOL)
        with self._lock:
            proc = self._start()
            try:
                proc.stdin.write(request)
                proc.stdin.flush()
                ok, value = _receive(pickle.load(proc.stdout))
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


def _shared_folder() -> str:
    return "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else tempfile.gettempdir()


def _answer(value, folder: str) -> tuple[bytes, str | None]:
    """(what to write to the pipe, the shared-memory file it names or None): ``value`` pickled once, its out-of-band
    buffers of `SHARED_BYTES` or more in all written to a file in ``folder`` that the caller reads (``("shared",
    pickle, path, size, spans)``), else sent beside the pickle (``("inline", pickle, buffers)``)."""
    buffers: list[pickle.PickleBuffer] = []
    data = pickle.dumps(value, protocol=5, buffer_callback=buffers.append)
    views = [b.raw() for b in buffers]
    if sum(v.nbytes for v in views) < SHARED_BYTES:
        return _inline(data, views), None
    path, spans, at = None, [], 0
    try:
        fd, path = tempfile.mkstemp(prefix=f"rvn-helper-{os.getpid()}-", dir=folder)
        with os.fdopen(fd, "wb") as fh:
            for v in views:
                at = -(-at // _ALIGN) * _ALIGN
                fh.seek(at)
                fh.write(v)
                spans.append((at, v.nbytes))
                at += v.nbytes
    except OSError:  # no room there: through the pipe
        _delete(path)
        return _inline(data, views), None
    return pickle.dumps(("shared", data, path, at, spans)), path


def _inline(data: bytes, views: list[memoryview]) -> bytes:
    """An answer's pickle with its out-of-band buffers beside it, all through the pipe."""
    return pickle.dumps(("inline", data, [v.tobytes() for v in views]), protocol=pickle.HIGHEST_PROTOCOL)


def _receive(message):
    """The answer `_answer` made: unpickled, its shared buffers read from their file in one call (then deleted) into
    one writable block the arrays share."""
    if message[0] == "inline":  # buffers as bytes: made writable, as the shared block is
        return pickle.loads(message[1], buffers=[bytearray(b) for b in message[2]])
    _, data, path, size, spans = message
    block = bytearray(size)
    try:
        with open(path, "rb", buffering=0) as fh:
            got = 0
            while got < size:
                n = fh.readinto(memoryview(block)[got:])
                if not n:
                    raise EOFError(f"{path} ended at {got} of {size} bytes")
                got += n
    finally:
        os.unlink(path)
    view = memoryview(block)
    return pickle.loads(data, buffers=[view[a:a + n] for a, n in spans])


def _delete(path: str | None) -> None:
    if path is not None:
        try:
            os.unlink(path)
        except FileNotFoundError:  # the caller took it
            pass


def main() -> None:
    """The helper's loop: a call (function, arguments) in, (True, its result) or (False, its exception) out, until
    its input ends."""
    source, sink = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # what the functions print goes to the parent's stderr, not into the answers' pipe
    from rvn_data.warning_lines import install_from_env

    install_from_env()  # a scene's warnings as the parent's run says them, once (rvn_data.warning_lines)
    last = None  # the last answer's shared file, deleted by the caller when it took the answer
    try:
        while True:
            try:
                fn, args, folder = pickle.load(source)
            except EOFError:
                return
            _delete(last)  # the caller asks again: it read the last answer (or died reading it)
            try:
                answer, last = _answer((True, fn(*args)), folder)
            except Exception as err:  # raised in the caller's process
                try:
                    answer, last = _answer((False, err), folder)
                except Exception:  # an exception that does not pickle: its text
                    answer, last = _answer((False, RuntimeError(f"{type(err).__name__}: {err}")), folder)
            sink.write(answer)
            sink.flush()
    finally:
        _delete(last)


if __name__ == "__main__":
    main()
