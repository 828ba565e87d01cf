"""rvn_data.warning_lines: a run's warnings in one line named by the command, each once across its processes."""
from __future__ import annotations

import os
import subprocess
import sys
import warnings

from rvn_data.warning_lines import ONCE_DIR, PROG, said_once

WORKER = ("from rvn_data.warning_lines import install_from_env; install_from_env(); import warnings; "
          "warnings.warn('scene a: tilted'); warnings.warn('scene b: tilted')")


def test_each_message_once_across_the_run_and_its_workers(capsys):
    with said_once("rvn-test"):
        warnings.warn("scene a: tilted")  # said here first
        workers = [subprocess.run([sys.executable, "-c", WORKER], capture_output=True, text=True, timeout=60)
                   for _ in range(2)]
    here = capsys.readouterr().err.splitlines()
    assert here == ["rvn-test: warning: scene a: tilted"]
    said = [w.stderr.splitlines() for w in workers]
    assert sorted(said) == [[], ["rvn-test: warning: scene b: tilted"]], said  # b: the first worker's; a: nobody's
    assert ONCE_DIR not in os.environ and PROG not in os.environ  # the run's folder is gone with it


def test_outside_a_run_a_worker_warns_as_python_does():
    proc = subprocess.run([sys.executable, "-c", WORKER], capture_output=True, text=True, timeout=60,
                          env={k: v for k, v in os.environ.items() if k not in (ONCE_DIR, PROG)})
    assert proc.stderr.count("UserWarning: scene") == 2 and "rvn-test" not in proc.stderr


def test_without_a_writable_temporary_folder_each_process_says_it_in_one_line(monkeypatch, capsys):
    import tempfile

    def unwritable(*args, **kwargs):
        raise PermissionError("read-only /tmp")

    monkeypatch.setattr(tempfile, "mkdtemp", unwritable)
    with said_once("rvn-test"):
        warnings.warn("scene c: tilted")
        worker = subprocess.run([sys.executable, "-c", WORKER], capture_output=True, text=True, timeout=60)
    assert capsys.readouterr().err.splitlines() == ["rvn-test: warning: scene c: tilted"]
    assert worker.stderr.splitlines() == ["rvn-test: warning: scene a: tilted", "rvn-test: warning: scene b: tilted"]
