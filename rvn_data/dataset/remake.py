"""The rvn-gen command that redoes a dataset's damaged trajectories, for the messages that ask for it.

rvn-gen records the overrides of each generating run in ``<out_dir>/.rvn/command.json``
(`record_command`). Rerun into the same out_dir, it checks every trajectory it recorded and
redoes what is missing or damaged (`rvn_data.dataset.scene_job`), deterministically, so the
command of the run that made a dataset repairs it. `remake_command` prints it: ``rvn-gen
out_dir=<root>`` and the recorded overrides, without the shard settings (one run over the
whole scene list checks every scene, redoes the damaged ones and writes the splits). Datasets
made before the record existed: Hydra's ``<root>/.hydra/overrides.yaml`` when present, else the
settings in ``.rvn/settings.json`` are named.
"""
from __future__ import annotations

import json
import shlex
from pathlib import Path
from typing import Sequence

import yaml

from rvn_data.atomic import write_text_atomic

COMMAND = "command.json"
_DROPPED = ("out_dir", "shard_index", "num_shards", "mode")  # out_dir comes first, absolute


def record_command(out_dir: str | Path, overrides: Sequence[str]) -> None:
    """Record the overrides of a generating rvn-gen run into ``out_dir`` (atomically; the last run's)."""
    text = json.dumps({"tool": "rvn-gen", "overrides": [str(o) for o in overrides]}, indent=1) + "\n"
    path = Path(out_dir) / ".rvn" / COMMAND
    if not path.is_file() or path.read_text() != text:
        write_text_atomic(path, text)


def _key(override: str) -> str:
    return override.split("=", 1)[0].lstrip("+~")


def recorded_overrides(root: str | Path) -> list[str] | None:
    """The overrides of the rvn-gen run recorded in ``root``, or None when none is."""
    root = Path(root)
    for path, read in ((root / ".rvn" / COMMAND, lambda t: json.loads(t)["overrides"]),
                       (root / ".hydra" / "overrides.yaml", yaml.safe_load)):
        try:
            found = read(path.read_text())
        except (OSError, ValueError, KeyError, TypeError, yaml.YAMLError):
            continue
        if isinstance(found, list):
            return [str(o) for o in found]
    return None


def remake_command(root: str | Path) -> str | None:
    """``rvn-gen out_dir=<root> <recorded overrides>``, or None when ``root`` has no record."""
    root = Path(root).expanduser().resolve()
    overrides = recorded_overrides(root)
    if overrides is None:
        return None
    kept = [o for o in overrides if _key(o) not in _DROPPED]
    return shlex.join(["rvn-gen", f"out_dir={root}", *kept])


def remake_hint(root: str | Path, what: str = "it") -> str:
    """The end of a message about a damaged trajectory of ``root``: how to redo ``what``."""
    root = Path(root).expanduser().resolve()
    command = remake_command(root)
    if command is not None:
        return f"rerun the rvn-gen command that made {root} (same out_dir) to redo {what}: {command}"
    if (root / ".rvn" / "settings.json").is_file():
        return (f"rerun the rvn-gen command that made {root} (same out_dir and settings, recorded in "
                f"{root / '.rvn' / 'settings.json'}) to redo {what}")
    return f"restore or regenerate {what}, or remove it from the split's traj_names.txt"


__all__ = ["COMMAND", "recorded_overrides", "record_command", "remake_command", "remake_hint"]
