"""Paths a notebook is given, resolved from where the user started Jupyter.

A Jupyter kernel runs in the notebook's folder (``notebooks/``), but a user types paths
relative to the folder they started ``jupyter lab`` in (the README's
``RVN_DATASET=outputs/rvn_negative jupyter lab``, from the repository root). The kernel
inherits the shell's ``PWD``, which still names that folder; ``RVN_LAUNCH_DIR`` overrides it,
and without either the kernel's own folder is used. Absolute paths are taken as they are.

Clips (animations) go under the cache root (`rvn_data.cache_root`): ``RVN_CLIPS_OUT`` if set,
else ``$RVN_CACHE_DIR/clips/<dataset>-<key>``, else ``<launch folder>/outputs/cache/clips/
<dataset>-<key>`` (``outputs/`` is where rvn-gen writes and is ignored by git), never the
dataset or the repository's ``notebooks/``.
"""
from __future__ import annotations

import os
from pathlib import Path

from rvn_data.cache_root import cache_root, settings_key

LAUNCH_ENV = "RVN_LAUNCH_DIR"
DATASET_ENV = "RVN_DATASET"
CLIPS_ENV = "RVN_CLIPS_OUT"
DEFAULT_DATASET = "outputs/rvn_negative"  # rvn-gen dataset=negative's default out_dir


def launch_dir() -> Path:
    """The folder relative paths are read from: ``$RVN_LAUNCH_DIR``, else ``$PWD`` (the shell's
    folder when Jupyter started), else the current directory."""
    for name in (LAUNCH_ENV, "PWD"):
        value = os.environ.get(name)
        if value and Path(value).is_dir():
            return Path(value).resolve()
    return Path.cwd()


def from_launch(path: str | os.PathLike) -> Path:
    """``path`` (``~`` expanded) made absolute against `launch_dir`."""
    p = Path(path).expanduser()
    return p if p.is_absolute() else launch_dir() / p


def dataset_path(value: str | os.PathLike | None = None) -> Path:
    """The dataset folder: ``value``, else ``$RVN_DATASET``, else ``outputs/rvn_negative``,
    resolved from the launch folder; ValueError naming the path and how it was read when missing."""
    given = value if value is not None else os.environ.get(DATASET_ENV) or DEFAULT_DATASET
    source = "DATASET" if value is not None else DATASET_ENV if os.environ.get(DATASET_ENV) else "the default"
    path = from_launch(given)
    if not path.is_dir():
        how = "" if Path(given).expanduser().is_absolute() else f", relative to {launch_dir()} (the folder Jupyter " \
              f"started in: ${LAUNCH_ENV} or $PWD)"
        raise ValueError(f"dataset folder {path} does not exist ({source} = {given}{how}); make one with "
                         f"`rvn-gen dataset=negative` or set {DATASET_ENV} to an rvn-gen output folder")
    return path


def clips_dir(dataset: str | os.PathLike) -> Path:
    """Where the clips of ``dataset`` are written: ``$RVN_CLIPS_OUT`` (from the launch folder),
    else ``<cache root>/clips/<dataset name>-<key of its absolute path>``."""
    if os.environ.get(CLIPS_ENV):
        return from_launch(os.environ[CLIPS_ENV])
    dataset = Path(dataset).resolve()
    root = cache_root(None, launch_dir() / "outputs")
    return root / "clips" / f"{dataset.name}-{settings_key(str(dataset), 8)}"
