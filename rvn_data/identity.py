"""The one identity check for everything RVN resumes into: rvn-gen's out_dir
(``.rvn/settings.json``), rvn-eval's out_dir (``run.json``) and the episode cache (index and
scene files). Each records the settings it was made with; a later run with other settings is
refused with one line that names the file and every setting that differs, as the command
line spells it.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Mapping



class _Missing:
    """A setting a record leaves out: one at its default (records omit a few of those: `navmesh.settings.recorded`)
    or one the file's version did not have."""

    def __repr__(self) -> str:
        return "its default"

    def __str__(self) -> str:
        return "default"


MISSING = _Missing()


def flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested settings as dotted keys: {"agent": {"r_robot": 0.18}} → {"agent.r_robot": 0.18}."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def differences(stored: Mapping[str, Any], wanted: Mapping[str, Any]) -> list[tuple[str, Any, Any]]:
    """(dotted key, stored value, wanted value) of every setting that differs, sorted by key."""
    a, b = flatten(stored), flatten(wanted)
    return [(k, a.get(k, MISSING), b.get(k, MISSING)) for k in sorted(set(a) | set(b))
            if a.get(k, MISSING) != b.get(k, MISSING)]


def check_identity(path: str | Path, stored: Mapping[str, Any], wanted: Mapping[str, Any], what: str,
                   hint: str, name: Callable[[str], str] = str) -> None:
    """ValueError when ``stored`` (read from ``path``) differs from this run's ``wanted``:
    ``<what> <path> was made with k=a but this run uses k=b (and ...); <hint>``. ``name`` maps
    a dotted key to the setting's name on the command line; ``{dir}`` in ``hint`` is the
    file's folder."""
    diff = differences(stored, wanted)
    if not diff:
        return
    (k, a, b), more = diff[0], diff[1:]
    extra = f" (also {', '.join(f'{name(k2)}: {a2!r} -> {b2!r}' for k2, a2, b2 in more)})" if more else ""
    raise ValueError(f"{what} {path} was made with {name(k)}={a!r} but this run uses {name(k)}={b!r}{extra}; "
                     + hint.format(dir=Path(path).parent))


def other_dir(path: str | Path, stored: Mapping[str, Any], wanted: Mapping[str, Any]) -> Path:
    """A folder beside ``path`` named after (up to two of) the settings this run changes, e.g.
    ``runs/eval/val/nomad`` -> ``runs/eval/val/nomad_aggregatevote``: what a refused run can use instead."""
    import re

    path = Path(path)
    tags = [re.sub(r"[^A-Za-z0-9._-]+", "", f"{k.split('.')[-1]}{b}")[:40] for k, _, b in differences(stored, wanted)[:2]]
    return path.parent / "_".join([path.name, *[t for t in tags if t]])
