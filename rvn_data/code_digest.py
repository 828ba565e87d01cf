"""Digests of Python sources' code, for the keys of caches whose files depend on what the code computes (the
navmesh cache, `rvn_data.navmesh.disk_cache`; the goal-pool cache, `rvn_data.benchmark.pool_cache`).

A key that hashed a module's bytes made every kept file stale at any edit of its docstrings or comments: the next
run solved every scene's navmesh and goal pool again (tens of seconds an HM3D scene), for the same arrays. So a
source's digest is of its `code_text`: the source with its comments, its docstrings (a module's, class's or
function's first statement when that is a string) and its blank lines and trailing spaces left out. Any other change,
code or a string that is not a docstring, changes it. The text is cut from the source at the positions Python's own
parser and tokenizer give, not re-printed from the syntax tree or joined from tokens, whose forms change between
Python versions (`ast.unparse`'s, and f-strings' tokens since 3.12); only Python 3.11 has been tried. A process
works it out once (`lru_cache` at the callers): ~0.11 s for the navmesh package's 18 files (147 kB, 2-core
development CPU; hashing their bytes had taken ~1 ms).
"""
from __future__ import annotations

import ast
import hashlib
import io
import tokenize
from collections.abc import Iterable
from pathlib import Path

FORMAT = "rvn-code-text/1"  # bump when code_text changes what it leaves out


def _docstrings(tree: ast.Module) -> Iterable[ast.Expr]:
    """Each module's, class's and function's docstring statement."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                    and isinstance(first.value.value, str):
                yield first


def code_text(source: str, name: str = "<source>") -> str:
    """``source`` without its comments, docstrings, blank lines and trailing spaces (lines otherwise as written).
    SyntaxError naming ``name`` where it does not parse."""
    source = source.replace("\r\n", "\n").replace("\r", "\n")
    lines = source.split("\n")  # the parser's rows (str.splitlines would also split at form feeds and the like)
    try:
        tree = ast.parse(source, filename=name)
        tokens = tokenize.generate_tokens(io.StringIO(source).readline)
        comments = [tok for tok in tokens if tok.type == tokenize.COMMENT]
    except (SyntaxError, tokenize.TokenError) as err:
        raise SyntaxError(f"{name}: not Python source ({err}); its code digest needs it to parse") from None

    def column(row: int, byte_offset: int) -> int:  # ast's columns count UTF-8 bytes, tokenize's characters
        return len(lines[row - 1].encode()[:byte_offset].decode(errors="ignore"))

    spans = [(tok.start, tok.end) for tok in comments]  # ((row, column), (row, column))
    spans += [((e.lineno, column(e.lineno, e.col_offset)), (e.end_lineno, column(e.end_lineno, e.end_col_offset)))
              for e in _docstrings(tree)]
    kept = list(lines)
    for (row0, col0), (row1, col1) in sorted(spans, reverse=True):  # from the end: earlier positions stay valid
        if row0 == row1:
            kept[row0 - 1] = kept[row0 - 1][:col0] + kept[row0 - 1][col1:]
        else:
            kept[row0 - 1] = kept[row0 - 1][:col0]
            kept[row1 - 1] = kept[row1 - 1][col1:]
            for row in range(row0, row1 - 1):
                kept[row] = ""
    return "\n".join(line.rstrip() for line in kept if line.strip())


def code_digest(paths: Iterable[str | Path], extra: str = "") -> str:
    """sha256 (hex) of ``extra`` and each file's name and `code_text`, in the order given."""
    h = hashlib.sha256(f"{FORMAT}\n{extra}".encode())
    for path in paths:
        path = Path(path)
        h.update(f"\n{path.name}\n".encode())
        h.update(code_text(path.read_text(encoding="utf-8"), str(path)).encode())
    return h.hexdigest()
