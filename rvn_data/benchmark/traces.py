"""Episode traces: where the agent went in each rvn-eval episode (``paths=true``), for maps and collision clips
(`rvn_data.benchmark.trace_maps`).

A trace holds the agent's pose before its first step and after every step (positions float32 [T+1, 3], yaws
float32 [T+1], goals reached so far int16 [T+1]), the episode's goals float32 [N_goal, 3], its scene's spec and id
and how it ended. One file an episode, ``out_dir/paths/<scene index>-<episode index>.npz``, written atomically
before the episode's line in ``episodes.jsonl``: a record implies its trace, and an interrupted run resumes with
both (an episode run again writes the same file). A run started over (``resume=false``) removes the traces and
pictures of the one before (`prune_traces`). A run resumed with ``paths=true`` after episodes ran without it has no
trace of those; the maps say how many.
"""
from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from rvn_data.atomic import write_bytes_atomic

FOLDER = "paths"


class TraceRecorder:
    """The poses of one episode of an eval-mode `RVNEnv`, from its reset to its end."""

    def __init__(self, env):
        env = env.unwrapped
        self.env = env
        self.positions, self.yaws, self.reached = [env.position.copy()], [env.yaw], [0]

    def step(self, info: dict) -> None:
        self.positions.append(self.env.position.copy())
        self.yaws.append(self.env.yaw)
        self.reached.append(int(info["goals_reached"]))

    def arrays(self, record: dict) -> dict:
        """The trace of the finished episode whose record is ``record``."""
        env = self.env
        return {"positions": np.asarray(self.positions, np.float32), "yaws": np.asarray(self.yaws, np.float32),
                "goals_reached": np.asarray(self.reached, np.int16),
                "goals": np.asarray(env.episode.goals, np.float32), "spec": np.str_(env.scene_spec),
                "scene_id": np.str_(record["scene_id"]), "termination": np.str_(record["termination"])}


def trace_file(out_dir: str | Path, scene_index: int, episode_index: int) -> Path:
    return Path(out_dir) / FOLDER / f"{int(scene_index):05d}-{int(episode_index):04d}.npz"


def write_trace(out_dir: str | Path, record: dict, trace: dict) -> Path:
    """Write ``trace`` (`TraceRecorder.arrays`) of the episode ``record`` atomically; its path."""
    path = trace_file(out_dir, record["scene_index"], record["episode_index"])
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:  # np.savez_compressed's layout, dated 1980: same bytes
        for name, value in trace.items():
            array = io.BytesIO()
            np.lib.format.write_array(array, np.asarray(value), allow_pickle=False)
            z.writestr(zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0)), array.getvalue(),
                       compress_type=zipfile.ZIP_DEFLATED)
    write_bytes_atomic(path, buf.getvalue())
    return path


def prune_traces(out_dir: str | Path, done) -> int:
    """Before a run's episodes: remove the traces of episodes whose record is not among ``done`` (keys (scene index,
    episode index)), of a run started over (resume=false) or written just before an interruption (run again, the
    episode writes it again), and with no episode done the pictures drawn from them (``maps/``, ``clips/``); how many
    traces were removed."""
    out, removed = Path(out_dir), 0
    traces = sorted((out / FOLDER).glob("[0-9]*-[0-9]*.npz"))
    for path in traces:
        scene, episode = (int(x) for x in path.stem.split("-"))
        if (scene, episode) not in done:
            path.unlink()
            removed += 1
    if traces and not done:  # the pictures of a run of ours (it left traces), only the files trace_maps writes
        for folder, patterns in (("maps", ("*.png",)), ("clips", ("*.gif", "*.mp4"))):
            for pattern in patterns:
                for f in (out / folder).glob(pattern):
                    f.unlink()
            if (out / folder).is_dir() and not any((out / folder).iterdir()):
                (out / folder).rmdir()
    return removed


def read_trace(path: str | Path) -> dict:
    """A trace file's arrays (strings as str)."""
    with np.load(path, allow_pickle=False) as z:
        return {k: (str(z[k]) if z[k].dtype.kind == "U" else z[k]) for k in z.files}
