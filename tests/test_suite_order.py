"""The suite's own scheduling (tests/conftest.py): the longest files, which xdist hands out first, exist by those
names, so a renamed file cannot quietly fall back to the end of the queue and leave one core running it alone; while
numba's kernels compile for the workers, a test waits for them unless its file needs none."""
from __future__ import annotations

import os
from pathlib import Path
from types import SimpleNamespace

from conftest import KERNEL_FREE, LONGEST_FIRST, WARMING, pytest_collection_modifyitems, pytest_runtest_setup

HERE = Path(__file__).resolve().parent


def test_longest_first_names_test_files_of_this_suite_once():
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)
    missing = [name for name in LONGEST_FIRST if not (HERE / name).is_file()]
    assert not missing, f"tests/conftest.py LONGEST_FIRST names files that are not in tests/: {missing}"
    assert LONGEST_FIRST[0] in KERNEL_FREE  # a worker's first file runs while the kernels compile


def test_collection_puts_them_first_in_their_order_and_keeps_the_rest_stable():
    names = ["test_a.py", LONGEST_FIRST[2], "test_b.py", LONGEST_FIRST[0], "test_a.py"]
    items = [SimpleNamespace(path=HERE / n, tag=i) for i, n in enumerate(names)]
    pytest_collection_modifyitems(None, items)
    assert [(i.path.name, i.tag) for i in items] == [(LONGEST_FIRST[0], 3), (LONGEST_FIRST[2], 1), ("test_a.py", 0),
                                                     ("test_b.py", 2), ("test_a.py", 4)]


def test_a_worker_waits_for_the_kernels_unless_its_file_needs_none(tmp_path, monkeypatch):
    import threading

    done = tmp_path / "done"
    monkeypatch.setenv(WARMING, str(done))
    pytest_runtest_setup(SimpleNamespace(path=HERE / KERNEL_FREE[0]))
    assert os.environ[WARMING] == str(done) and not done.exists()  # no wait: the kernels are still compiling
    threading.Timer(0.5, done.touch).start()
    pytest_runtest_setup(SimpleNamespace(path=HERE / "test_env.py"))
    assert done.exists()  # waited for the warm-up's end
    assert WARMING not in os.environ  # later tests do not look again
