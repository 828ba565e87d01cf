"""What code produced a result: recorded in rvn-eval's ``run.json`` and ``metrics.json`` and in
rvn-train's / rvn-rl's ``config.yaml`` under ``provenance``, and printed per row by the report.

    {"commit": "45b2f36…", "code_commit": "1cf5eea…", "dirty": false, "version": "0.1.0", "generator_version": 2}

``commit`` is the git commit (HEAD) of the checkout the ``rvn_data`` package was imported from (an
editable install of a clone); ``code_commit`` the last commit that changed the code (`CODE_PATHS`: the
packages, ``conf/``, ``jobs/``, ``pyproject.toml``), so results committed under ``docs/`` while a
recipe runs do not make its later steps look like other code; ``dirty`` says whether the code
differed from ``code_commit`` (changed or new files there that git does not ignore). All three are
null when the package is not in a git checkout (an installed wheel) or git is missing. Tables show
``code_commit`` (`short`). ``generator_version`` is the benchmark episode generator's
(`rvn_data.benchmark.episodes.GENERATOR_VERSION`): runs of different versions saw different episodes.
Computed once per process.
"""
from __future__ import annotations

import subprocess
from functools import lru_cache
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
CODE_PATHS = ("rvn_data", "rvn_il", "rvn_rl", "conf", "jobs", "pyproject.toml")


def _git(*args: str) -> str | None:
    try:
        proc = subprocess.run(["git", "-C", str(PACKAGE_DIR.parent), *args], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return proc.stdout if proc.returncode == 0 else None


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rvn")
    except PackageNotFoundError:
        return "unknown"


@lru_cache(maxsize=1)
def provenance() -> dict:
    """This process's code: git commit and dirtiness of the checkout, package and episode generator versions."""
    from rvn_data.benchmark.episodes import GENERATOR_VERSION

    top = _git("rev-parse", "--show-toplevel")
    commit = code = dirty = None
    if top is not None and Path(top.strip()).resolve() == PACKAGE_DIR.parent:  # not a parent repo's checkout
        head = _git("rev-parse", "HEAD")
        last = _git("log", "-1", "--format=%H", "--", *CODE_PATHS)
        status = _git("status", "--porcelain", "--", *CODE_PATHS)
        commit = head.strip() if head else None
        code = last.strip() if last and last.strip() else commit
        dirty = None if status is None else bool(status.strip())
    return {"commit": commit, "code_commit": code, "dirty": dirty, "version": package_version(),
            "generator_version": GENERATOR_VERSION}


def short(prov: dict | None) -> str:
    """The code commit as ``1cf5eea`` / ``1cf5eea+dirty`` / ``unknown`` for a table cell."""
    commit = (prov or {}).get("code_commit") or (prov or {}).get("commit")
    if not commit:
        return "unknown"
    return str(commit)[:7] + ("+dirty" if prov.get("dirty") else "")


def provenance_record(earlier: dict | None, resuming: bool) -> dict:
    """``{"provenance": ...}`` for a config file written at the start of a run, with ``resumed_by``
    when the run resumes work that other code started: ``earlier`` is what the out_dir's file
    recorded (``provenance`` and ``resumed_by`` keys; None or {} when none), ``resuming`` whether
    the run continues existing work (checkpoints) rather than starting over."""
    now = provenance()
    earlier = earlier or {}
    if not resuming or not earlier.get("provenance"):
        return {"provenance": now}
    first, later = earlier["provenance"], list(earlier.get("resumed_by") or [])
    if short(now) not in {short(p) for p in [first, *later]}:
        later.append(now)
    return {"provenance": first, **({"resumed_by": later} if later else {})}
