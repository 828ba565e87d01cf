"""Code that runs on Python 3.11 and fails on 3.12: a list, set or dict comprehension's variable that shadows a
name the same function reads elsewhere.

Python 3.12 inlines those comprehensions into their function (PEP 709), so their variable becomes one of the
function's local names, unbound outside the comprehension: where the function (or a comprehension, generator
expression or lambda in it) reads that name meaning an outer one, 3.12 raises UnboundLocalError or NameError where
3.11 read the outer one. It happened: `UNet1D.packed_weights` named a comprehension's variable `blk`, the name of
the helper its other comprehensions call, and every NoMaD decision on a GPU node's Python 3.12 failed
(docs/results/2026-12-04_gpu4) while the whole suite passed on 3.11, the CI's Python. pyproject says >= 3.11.

This test reads the source (ast) of every Python file of the packages, benchmarks, jobs and tests, so it runs on
3.11 too, and names each such variable; renaming it mends it."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INLINED = (ast.ListComp, ast.SetComp, ast.DictComp)  # generator expressions keep a scope of their own
SCOPES = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef, ast.GeneratorExp)


def _comp_names(comp) -> set[str]:
    return {t.id for g in comp.generators for t in ast.walk(g.target) if isinstance(t, ast.Name)}


def _own(scope) -> list[ast.AST]:
    """The nodes that run in ``scope`` itself: down into inlined comprehensions, not into nested scopes."""
    out, stack = [], list(ast.iter_child_nodes(scope))
    while stack:
        n = stack.pop()
        out.append(n)
        if not isinstance(n, SCOPES):
            stack.extend(ast.iter_child_nodes(n))
    return out


def _binds(scope, name: str) -> bool:
    """Whether ``scope`` binds ``name`` other than as an inlined comprehension's variable."""
    args = scope.args if isinstance(scope, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) else None
    if args is not None and name in {a.arg for a in ast.walk(args) if isinstance(a, ast.arg)}:
        return True
    own = _own(scope)
    comp_targets = {id(t) for n in own if isinstance(n, INLINED) for g in n.generators for t in ast.walk(g.target)}
    for n in own:
        if isinstance(n, ast.Name) and isinstance(n.ctx, (ast.Store, ast.Del)) and id(n) not in comp_targets:
            if n.id == name:
                return True
        elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and n.name == name:
            return True
        elif isinstance(n, (ast.Import, ast.ImportFrom)) and name in {(a.asname or a.name).split(".")[0]
                                                                      for a in n.names}:
            return True
        elif isinstance(n, (ast.Global, ast.Nonlocal)) and name in n.names:
            return True
        elif isinstance(n, ast.ExceptHandler) and n.name == name:
            return True
    return False


def shadowing(source: str) -> list[tuple[int, str, int]]:
    """(line of the comprehension, its variable, line of a read that 3.12 resolves to it) for each case in
    ``source``."""
    tree = ast.parse(source)
    parents = {id(c): p for p in ast.walk(tree) for c in ast.iter_child_nodes(p)}
    found = []
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        for comp in (n for n in _own(fn) if isinstance(n, INLINED)):
            for name in sorted(_comp_names(comp)):
                if _binds(fn, name):
                    continue  # a local of the function anyway: the same on 3.11 and 3.12
                for read in ast.walk(fn):
                    if not (isinstance(read, ast.Name) and read.id == name and isinstance(read.ctx, ast.Load)):
                        continue
                    # the nearest enclosing thing that binds the name decides; a read in the function's own code
                    # outside any comprehension or nested function still finds the outer name on 3.12
                    p, crossed = parents[id(read)], False
                    while p is not fn and not ((isinstance(p, (*INLINED, ast.GeneratorExp)) and name in _comp_names(p))
                                               or (isinstance(p, SCOPES[:3]) and _binds(p, name))):
                        crossed |= isinstance(p, (*INLINED, *SCOPES))
                        p = parents[id(p)]
                    if p is fn and crossed:
                        found.append((comp.lineno, name, read.lineno))
    return sorted(set(found))


def test_the_check_finds_what_failed_on_python_3_12():
    # UNet1D.packed_weights before the fix, reduced: UnboundLocalError on 3.12 at blk(r)
    failed = ("def packed():\n    def blk(b):\n        return b\n    def build():\n"
              "        film = [blk.weight for blk in blocks()]\n        return [blk(r) for r in film]\n"
              "    return build()\n")
    assert shadowing(failed) == [(5, "blk", 6)]
    # a lambda and a generator expression reading it fail on 3.12 too (NameError)
    assert shadowing("def f():\n    a = [x for x in y]\n    return lambda: x\n") == [(2, "x", 3)]
    assert shadowing("def f():\n    a = [x for x in y]\n    return list(x for _ in y)\n") == [(2, "x", 3)]
    # what is the same on both: the outer name read in the function's own code, the variable read in its own
    # comprehension, in another that binds it, in a nested function that binds it, or a name the function binds
    assert shadowing("def f():\n    a = [x for x in y]\n    return x(a)\n") == []
    assert shadowing("def f():\n    a = [x for x in y]\n    b = {x: 1 for x in a}\n    return a, b\n") == []
    assert shadowing("def f():\n    a = [x for x in y]\n    def g():\n        for x in a:\n            pass\n"
                     "        return x\n    return g\n") == []
    assert shadowing("def f():\n    x = 1\n    a = [x for x in y]\n    return [x for _ in a]\n") == []


def test_no_comprehension_shadows_a_name_its_function_reads():
    files = sorted(str(f.relative_to(ROOT)) for d in ("rvn_data", "rvn_il", "rvn_rl", "benchmarks", "jobs", "tests")
                   for f in (ROOT / d).rglob("*.py"))
    assert len(files) > 100, files  # the packages' sources were found
    found = [f"{f}:{line}: comprehension variable {name!r} is read at line {read} as another name (Python >= 3.12 "
             "fails there: rename the comprehension's variable)"
             for f in files for line, name, read in shadowing((ROOT / f).read_text())]
    assert not found, "\n".join(found)
