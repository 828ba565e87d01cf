"""`rvn_data.helper_process.HelperProcess` (rvn-rl's scene prefetch): a function run in a process of its own gives
what it gives here; its exception is raised here; the process starts again after it died, names itself when it
fails, and ends on close."""
from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from rvn_data.helper_process import HelperProcess


def test_calls_run_in_another_process_and_raise_their_errors_here():
    helper = HelperProcess()
    try:
        assert helper.call(os.getpid) != os.getpid()
        a = np.arange(12.0).reshape(3, 4)
        assert np.array_equal(helper.call(np.cumsum, a, 1), np.cumsum(a, 1))
        with pytest.raises(ValueError, match="could not convert string to float"):
            helper.call(float, "ten")  # the helper's exception, raised in this process
        first = helper._proc
        assert helper.call(os.getpid) == first.pid  # one process for every call
        first.kill()
        first.wait()
        assert helper.call(os.getpid) not in (first.pid, os.getpid())  # started anew
        assert first.stdin.closed and first.stdout.closed
        with pytest.raises(RuntimeError, match=r"helper process .*failed in _exit.*env.prefetch_scenes=false"):
            helper.call(os._exit, 3)  # the process ends without an answer
    finally:
        helper.close()
    assert helper._proc is None


class Unpicklable(Exception):
    def __init__(self):
        super().__init__("held a lambda")
        self.held = lambda: 0


def raise_unpicklable():
    raise Unpicklable()


def test_what_does_not_pickle_fails_whole_and_the_helper_goes_on(monkeypatch):
    from pathlib import Path

    monkeypatch.setenv("PYTHONPATH", str(Path(__file__).parent))  # so that the helper imports this module
    helper = HelperProcess()
    try:
        with pytest.raises((AttributeError, pickle.PicklingError), match="pickle"):
            helper.call(len, lambda: 0)  # an argument that does not pickle: nothing was sent
        with pytest.raises(RuntimeError, match="Unpicklable: held a lambda"):
            helper.call(raise_unpicklable)  # an exception that does not pickle comes back as its text
        assert helper.call(int, "7") == 7  # the same process goes on
    finally:
        helper.close()


def big_arrays(n: int, fill: float):
    return {"a": np.full(n, fill, np.float32), "b": np.arange(n, dtype=np.int64), "small": np.ones(3)}


def test_large_answers_cross_in_shared_memory_and_leave_no_file(monkeypatch, tmp_path):
    """An answer whose arrays come to `SHARED_BYTES` or more crosses in a file in the helper's shared folder, which the
    caller reads and deletes: the same arrays, writable; smaller answers and errors come through the pipe, and so
    does a large answer where the folder cannot be written."""
    from pathlib import Path

    import rvn_data.helper_process as hp

    monkeypatch.setenv("PYTHONPATH", str(Path(__file__).parent))  # so that the helper imports this module
    kinds = []
    real = hp._receive
    monkeypatch.setattr(hp, "_receive", lambda message: (kinds.append(message[0]), real(message))[1])
    for folder in (tmp_path, tmp_path / "missing"):
        helper = HelperProcess(shared_folder=str(folder))
        try:
            got = helper.call(big_arrays, 200_000, 2.5)  # 2.4 MB
            assert np.array_equal(got["a"], np.full(200_000, 2.5, np.float32)) and got["b"][-1] == 199_999
            assert got["a"].flags.writeable and got["small"].tolist() == [1.0, 1.0, 1.0]
            got["a"][0] = 7.0
            assert got["a"][0] == 7.0 and got["b"].flags.writeable
            assert helper.call(big_arrays, 10, 1.0)["b"].tolist() == list(range(10))
            with pytest.raises(ValueError, match="could not convert"):
                helper.call(float, "ten")
        finally:
            helper.close()
        assert list(tmp_path.glob("rvn-helper-*")) == []
    assert kinds == ["shared", "inline", "inline", "inline", "inline", "inline"]
