"""rvn-gen's GNM dataset writer, one lifecycle (the way LeRobot's dataset writer reads):

    w = GNMWriter.open(out_dir, settings)     # writable? made with these settings? (records them)
    w.write_trajectory(name, jpegs, position, yaw, meta, depth)   # one folder, atomically
    w.close_scene(slug, record)               # the scene's record, last: a scene with one is done
    w.finalise(specs)                         # data_splits/, data_config.yaml, manifest.json

Scene jobs in worker processes write through ``GNMWriter(out_dir, settings)`` (opened once by
the parent). On resume, a folder is trusted only when `check` finds it whole
(`rvn_data.dataset.verify`: its pose file, sidecar, every frame and depth map); a damaged one
is `discard`-ed and written again.
Layout and atomicity of one folder: `rvn_data.dataset.writer`.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from rvn_data.dataset import finalise as _finalise
from rvn_data.dataset import writer
from rvn_data.dataset.reader import is_complete
from rvn_data.dataset.settings import DATASET_VERSION, DatasetConfig, GenSettings
from rvn_data.dataset.verify import MISSING, Expect, check_trajectory
from rvn_data.identity import check_identity, differences

SETTING_GROUPS = ("agent", "navmesh", "camera", "seed", "renderer", "scenes")  # other identity keys are dataset.*


class GNMWriter:
    """An rvn-gen output folder being written (see the module docstring)."""

    def __init__(self, out_dir: str | Path, settings: GenSettings):
        self.out_dir, self.settings = Path(out_dir), settings

    @classmethod
    def open(cls, out_dir: str | Path, settings: GenSettings) -> "GNMWriter":
        """Check that ``out_dir`` is writable and holds no dataset made with other settings
        (ValueError naming the setting), and record the settings; then write into it."""
        w = cls(out_dir, settings)
        w._check_writable()
        w._check_identity()
        return w

    def _check_writable(self) -> None:
        try:
            (self.out_dir / ".rvn").mkdir(parents=True, exist_ok=True)
            fd, probe = tempfile.mkstemp(prefix=".probe", dir=self.out_dir / ".rvn")  # a name of its own: shards on
            os.close(fd)                                                             # other nodes may share a pid
            os.unlink(probe)
        except OSError as e:
            raise ValueError(f"out_dir={self.out_dir}: cannot write there ({e.strerror or e}); "
                             "choose a writable out_dir") from None

    def _check_identity(self) -> None:
        path = self.out_dir / ".rvn" / "settings.json"
        mine = {**self.settings.identity(), "scenes": self.settings.scenes, "dataset_version": DATASET_VERSION}
        if path.is_file() and self._holds_work():
            stored, wanted = json.loads(path.read_text()), json.loads(writer.dumps_json(mine))
            made_by = stored.get("dataset_version", 1)
            if made_by != DATASET_VERSION:
                raise ValueError(f"out_dir={self.out_dir} holds a dataset of rvn-gen's dataset version {made_by} "
                                 f"({path}); this code makes version {DATASET_VERSION}, whose trajectories differ "
                                 "(rvn_data/dataset/settings.py says how): generate into another out_dir, or resume, "
                                 "extend or repair it with the code that began it")
            check_identity(path, stored, wanted, f"out_dir={self.out_dir} holds a dataset:",
                           f"use another out_dir (e.g. out_dir={self._other_dir(stored, wanted)}), "
                           "or the same settings to resume or extend it",
                           name=lambda k: k if k.split(".")[0] in SETTING_GROUPS else f"dataset.{k}")
            return
        writer.write_text_atomic(path, writer.dumps_json(mine))  # new, or nothing made yet: this run's settings

    def _holds_work(self) -> bool:
        """Whether an earlier run left anything made with its settings: a finished scene or a trajectory
        folder. A run that failed on every scene leaves neither, so the corrected command starts afresh."""
        if any((self.out_dir / ".rvn" / "scenes").glob("*.json")):
            return True
        return any(is_complete(p) for p in self.out_dir.iterdir() if p.is_dir() and not p.name.startswith("."))

    def _other_dir(self, stored: dict, wanted: dict) -> Path:
        """A folder beside out_dir named after the settings that differ (rvn_expert_perturb_prob0.1),
        those at their default left out."""
        diff = differences(stored, wanted)
        changed = [(k, b) for k, _, b in diff if getattr(DatasetConfig, k.split(".")[-1], None) != b] or \
            [(k, b) for k, _, b in diff]
        tags = [re.sub(r"[^A-Za-z0-9._-]+", "", f"{k.split('.')[-1]}{b}") for k, b in changed[:2]]
        return self.out_dir.parent / "_".join([self.out_dir.name, *tags])

    # -- one scene ------------------------------------------------------------------------
    def scene_record(self, slug: str) -> dict | None:
        """The record of a scene already closed, or None."""
        return writer.read_record(writer.record_path(self.out_dir, slug))

    def check(self, name: str, frames: int | None = None) -> tuple[str | None, dict | None]:
        """(None, sidecar) of a whole trajectory folder; (None, None) when it is absent and no
        record names it (``frames`` None: not written yet); (what is wrong, None) otherwise."""
        problem, meta = check_trajectory(self.out_dir / name, Expect.of_settings(self.settings), frames)
        return (None, None) if problem == MISSING and frames is None else (problem, meta)

    def done_trajectory(self, name: str) -> dict | None:
        """The sidecar of a whole trajectory folder already on disk, or None."""
        return self.check(name)[1]

    def discard(self, name: str) -> None:
        """Remove a damaged trajectory folder (moved out of sight first, then deleted)."""
        aside = self.out_dir / ".rvn" / "tmp" / f"{name}.damaged"
        for path in (aside, self.out_dir / name):
            if path.is_dir() and not path.is_symlink():
                aside.parent.mkdir(parents=True, exist_ok=True)
                if path != aside:
                    os.replace(path, aside)
                shutil.rmtree(aside)
            elif path.exists() or path.is_symlink():
                path.unlink()

    def write_trajectory(self, name: str, jpegs: list[bytes], position: np.ndarray, yaw: np.ndarray,
                         meta: dict, depth: np.ndarray | None = None) -> None:
        writer.write_trajectory(self.out_dir, name, jpegs, position, yaw, meta, depth)

    def write_map(self, slug: str, png: bytes) -> None:
        writer.write_text_atomic(self.out_dir / "maps" / f"{slug}.png", png)

    def close_scene(self, slug: str, record: dict) -> None:
        """Write the scene's record (deterministic, no timings): the scene is done."""
        writer.write_text_atomic(writer.record_path(self.out_dir, slug), writer.dumps_json(record))

    def note_failure(self, slug: str, error: str | None) -> None:
        """Keep (or, after a success, remove) the note of a scene whose job failed."""
        note = _finalise.failure_path(self.out_dir, slug)
        if error is not None:
            writer.write_text_atomic(note, error + "\n")
        elif note.is_file():
            note.unlink()

    # -- the dataset ----------------------------------------------------------------------
    def missing_scenes(self, specs: list[str]) -> list[str]:
        return _finalise.missing_scenes(self.out_dir, specs)

    def finalise(self, specs: list[str], allow_missing: bool = False) -> list[str]:
        """Splits, data_config.yaml and manifest.json from the scene records; returns the
        specs still missing."""
        return _finalise.finalise(self.out_dir, self.settings, specs, allow_missing)

    def finalise_dataset(self, specs: list[str], allow_missing: bool = False) -> _finalise.Finalised:
        """`finalise` with a report: what was kept from earlier runs, stale caches removed."""
        return _finalise.finalise_dataset(self.out_dir, self.settings, specs, allow_missing)
