"""Test probe of tests/test_worker_threads.py, on PYTHONPATH only there: with RVN_THREAD_PROBE=<folder> set,
every Python process started writes <folder>/<pid>.start.json, its command line and the thread variables it
started with (before any library loaded), and at a normal exit <pid>.exit.json, OpenCV's and torch's thread
counts (those loaded)."""
import atexit
import json
import os
import sys

VARS = ("LP_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "TORCHINDUCTOR_COMPILE_THREADS")
FOLDER = os.environ.get("RVN_THREAD_PROBE")


def _write(kind: str, data: dict) -> None:
    with open(os.path.join(FOLDER, f"{os.getpid()}.{kind}.json"), "w") as f:
        json.dump(data, f)


def _at_exit() -> None:
    cv2, torch = sys.modules.get("cv2"), sys.modules.get("torch")
    _write("exit", {"cv2": cv2.getNumThreads() if cv2 else None, "torch": torch.get_num_threads() if torch else None})


if FOLDER:
    with open("/proc/self/cmdline", "rb") as f:
        cmd = [c.decode() for c in f.read().split(b"\0") if c]
    _write("start", {"cmd": cmd, "env": {k: os.environ.get(k) for k in VARS}})
    atexit.register(_at_exit)
