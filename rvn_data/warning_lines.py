"""A command's warnings (a scan's tilted floor, a texture it cannot read) as one line named by the command, each
said once a run, from its worker processes too.

Python prints a warning in two lines (the file and line that raised it, then the source line) once per process: an
rvn-eval run with 2 workers said a scene's warning three times, into its progress bar. Within :func:`said_once` a
warning is printed as ``<prog>: warning: <message>`` through tqdm (above a progress bar); the first process of the
run to say a message claims it with a file of its own in a folder the run shares (``os.open`` with ``O_EXCL``:
atomic across processes), the others stay quiet. Worker processes inherit the folder through the environment and
call :func:`install_from_env` when they start.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import sys
import tempfile
import warnings

from rvn_data.worker_threads import environ

ONCE_DIR = "RVN_WARNINGS_ONCE_DIR"  # the run's folder of said messages
PROG = "RVN_WARNINGS_PROG"  # the command's name, as its lines begin


def _show(message, category, filename, lineno, file=None, line=None) -> None:
    text = " ".join(str(message).split())
    folder = os.environ.get(ONCE_DIR)
    if folder:
        try:
            os.close(os.open(os.path.join(folder, hashlib.sha1(text.encode()).hexdigest()),
                             os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return  # another process of the run said it
        except OSError:
            pass  # the folder is gone (the run ended): say it
    from tqdm import tqdm

    tqdm.write(f"{os.environ.get(PROG, 'rvn')}: warning: {text}", file=sys.stderr)


def install_from_env() -> None:
    """In a worker process of a run within :func:`said_once`: its warnings as the run's (nothing otherwise)."""
    if os.environ.get(PROG):
        warnings.showwarning = _show


@contextlib.contextmanager
def said_once(prog: str):
    """Within: warnings as one line beginning ``<prog>: warning:``, each message once across this process and the
    workers it starts (which call :func:`install_from_env`)."""
    try:
        folder = tempfile.mkdtemp(prefix="rvn-warnings-")
    except OSError:  # no writable temporary folder: each process says its warnings once, as Python would
        folder = ""
    try:
        with environ({ONCE_DIR: folder, PROG: prog}), warnings.catch_warnings():
            warnings.showwarning = _show
            yield
    finally:
        if folder:
            shutil.rmtree(folder, ignore_errors=True)
