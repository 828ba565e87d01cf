"""The caches' code digests (`rvn_data.code_digest`): docstrings and comments do not count, code does."""
from __future__ import annotations

from pathlib import Path

import pytest

from rvn_data.benchmark import pool_cache
from rvn_data.code_digest import code_digest, code_text
from rvn_data.navmesh import disk_cache

SOURCE = '''"""Module docstring,
on two lines."""
import math  # a comment


class Field:
    """A class docstring."""

    scale = "a string that is not a docstring"

    def value(self, x):
        """A method's docstring."""
        # a comment alone on its line
        return math.sqrt(x) * 2  # and one after code

    async def later(self):
        \'\'\'An async docstring.\'\'\'
        "a second string: an expression, not the docstring"
        return 1


def é(): "a docstring after a non-ASCII name"; return "é"
'''


def test_code_text_leaves_out_docstrings_comments_and_blank_lines():
    assert code_text(SOURCE).splitlines() == [
        "import math",
        "class Field:",
        '    scale = "a string that is not a docstring"',
        "    def value(self, x):",
        "        return math.sqrt(x) * 2",
        "    async def later(self):",
        '        "a second string: an expression, not the docstring"',
        "        return 1",
        'def é(): ; return "é"',
    ]


def test_code_text_is_the_same_for_crlf_sources():
    assert code_text(SOURCE.replace("\n", "\r\n")) == code_text(SOURCE)


def test_code_text_names_a_file_that_does_not_parse():
    with pytest.raises(SyntaxError, match="broken.py: not Python source"):
        code_text("def f(:\n", "broken.py")


def _package_copy(tmp_path: Path) -> list[Path]:
    folder = Path(disk_cache.__file__).parent
    paths = []
    for path in sorted(folder.glob("*.py")):
        paths.append(tmp_path / path.name)
        paths[-1].write_text(path.read_text(encoding="utf-8"), encoding="utf-8")
    return paths


def test_the_navmesh_packages_digest_ignores_docs_but_not_code(tmp_path):
    """A copy of the navmesh package: its digest is the cache's; editing every module's docstring and adding comments
    keeps it (the kept navmeshes and goal pools stay valid), editing a number in the code changes it."""
    import numpy as np
    import scipy

    paths = _package_copy(tmp_path)
    extra = f"numpy {np.__version__} scipy {scipy.__version__}"
    before = code_digest(paths, extra=extra)
    assert before == disk_cache.code_digest()
    for path in paths:
        text = path.read_text(encoding="utf-8")
        if text.startswith('"""'):
            text = '"""Edited: ' + text[3:]
        path.write_text("# a new comment\n" + text.replace("\n\n\n", "\n\n\n# between definitions\n"), encoding="utf-8")
    assert code_digest(paths, extra=extra) == before
    settings = tmp_path / "settings.py"
    text = settings.read_text(encoding="utf-8")
    assert "0.18" in text
    settings.write_text(text.replace("0.18", "0.19", 1), encoding="utf-8")
    assert code_digest(paths, extra=extra) != before


def test_the_goal_pools_digest_builds_on_the_navmesh_packages():
    here = Path(pool_cache.__file__).parent
    assert pool_cache.code_digest() == code_digest([here / "goal_pool.py", here / "pool_cache.py"],
                                                   extra=disk_cache.code_digest())
