"""Is a GNM trajectory folder whole? The check rvn-gen runs before it trusts a folder it
resumes, and rvn-train before it trains (so a damaged dataset is bad input, not a failed run).

A folder is whole when it exists; ``traj_data.pkl`` reads (`reader.load_traj_data`) and gives
T frames (the T its scene record names, when one does); with ``Expect.meta`` its ``rvn_meta.json``
reads and names the folder and T; ``0.jpg`` .. ``T-1.jpg`` exist, each starting with a JPEG
header whose frame size (read by Pillow) is the camera's (when known) and ending with the
end-of-image marker FFD9 (a truncated file lacks it); and, with ``Expect.depth_size`` = S, ``depth.npy`` holds
float16 [T, S, S] and every byte of it. Frames are not decoded: their headers and last bytes
tell all this (measured below, `benchmarks/verify.py`).
"""
from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvn_data.dataset.reader import DEPTH_NAME, META_NAME, TRAJ_DATA, load_traj_data, read_meta

SOI, EOI = b"\xff\xd8", b"\xff\xd9"
MISSING = "folder missing"


@dataclass(frozen=True)
class Expect:
    """What a whole folder holds besides the GNM files: frames of ``image_size`` (W, H),
    ``depth.npy`` with [S, S] maps (``depth_size``), rvn-gen's sidecar (``meta``)."""

    image_size: tuple[int, int] | None = None
    depth_size: int | None = None
    meta: bool = False

    @classmethod
    def of_dataset(cls, root: str | Path, depth: bool = True) -> "Expect":
        """From the settings rvn-gen recorded in ``<root>/.rvn/settings.json`` (camera size, and the
        depth sidecars when ``depth`` and the dataset saved them); nothing for other datasets."""
        try:
            s = json.loads((Path(root) / ".rvn" / "settings.json").read_text())
            size = (int(s["camera"]["width"]), int(s["camera"]["height"]))
        except (OSError, ValueError, KeyError, TypeError):
            return cls()
        return cls(size, int(s.get("depth_size", 16)) if depth and s.get("save_depth") else None)

    @classmethod
    def of_settings(cls, settings) -> "Expect":
        """What a whole folder of an rvn-gen dataset with these `GenSettings` holds: frames of the
        camera's size, rvn_meta.json, and depth.npy with dataset.save_depth."""
        return cls((settings.camera.width, settings.camera.height),
                   settings.depth_size if settings.save_depth else None, meta=True)


def jpeg_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from a JPEG file's header (Pillow reads the header only), or None when it is not one."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            return im.size if im.format == "JPEG" else None
    except (UnidentifiedImageError, OSError, SyntaxError):
        return None


def image_problem(path: Path, size: tuple[int, int] | None) -> str | None:
    """What is wrong with one frame file (``7.jpg missing``, ``7.jpg truncated``, ...), or None."""
    try:
        with open(path, "rb") as f:
            starts = f.read(2) == SOI
            n = f.seek(0, os.SEEK_END)
            f.seek(max(n - 16, 0))
            tail = f.read()
    except FileNotFoundError:
        return f"{path.name} missing"
    except OSError as e:
        return f"{path.name} unreadable ({e.strerror or e})"
    if n == 0:
        return f"{path.name} empty"
    if not starts:
        return f"{path.name} is not a JPEG"
    if not tail.rstrip(b"\x00").endswith(EOI):  # trailing zeros: padding some writers add
        return f"{path.name} truncated"
    found = jpeg_size(path)
    if found is None:
        return f"{path.name} has no JPEG frame header"
    if size is not None and tuple(found) != tuple(size):
        return f"{path.name} is {found[0]}x{found[1]} pixels, not {size[0]}x{size[1]}"
    return None


def depth_problem(path: Path, frames: int, size: int) -> str | None:
    """What is wrong with a depth sidecar (float16 [frames, size, size], complete), or None."""
    try:
        with open(path, "rb") as f:
            version = np.lib.format.read_magic(f)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _, dtype = read(f)
            start, end = f.tell(), os.fstat(f.fileno()).st_size
    except FileNotFoundError:
        return f"{DEPTH_NAME} missing"
    except (OSError, ValueError) as e:
        return f"{DEPTH_NAME} unreadable ({e})"
    if tuple(shape) != (frames, size, size) or dtype != np.float16:
        return f"{DEPTH_NAME} holds {dtype} {list(shape)}, not float16 [{frames}, {size}, {size}]"
    if end - start < int(np.prod(shape)) * dtype.itemsize:
        return f"{DEPTH_NAME} truncated"
    return None


def check_trajectory(folder: str | Path, expect: Expect = Expect(), frames: int | None = None) -> tuple[str | None, dict | None]:
    """(None, sidecar or None) for a whole folder, (what is wrong, None) otherwise; ``frames``:
    the frame count a record names for it."""
    folder = Path(folder)
    if not folder.is_dir():
        return MISSING, None
    if not (folder / TRAJ_DATA).is_file():
        return f"{TRAJ_DATA} missing", None
    try:
        t = len(load_traj_data(folder)[0])
    except ValueError:
        return f"{TRAJ_DATA} unreadable", None
    meta = None
    if expect.meta:
        try:
            meta = read_meta(folder)
        except ValueError:
            return f"{META_NAME} {'missing' if not (folder / META_NAME).is_file() else 'unreadable'}", None
        if meta.get("name") != folder.name or meta.get("frames") != t:
            return f"{META_NAME} names {meta.get('name')!r} with {meta.get('frames')} frames, not this folder's {t}", None
    if frames is not None and frames != t:
        return f"{TRAJ_DATA} has {t} frames, its scene record {frames}", None
    for i in range(t):
        problem = image_problem(folder / f"{i}.jpg", expect.image_size)
        if problem:
            return problem, None
    if expect.depth_size:
        problem = depth_problem(folder / DEPTH_NAME, t, expect.depth_size)
        if problem:
            return problem, None
    return None, meta


def damaged(root: str | Path, names: list[str], expect: Expect = Expect(), threads: int = 8) -> dict[str, str]:
    """name → what is wrong, for the folders of ``names`` under ``root`` that are not whole
    (in the order of ``names``); folders are checked on ``threads`` threads (file reads)."""
    root = Path(root)
    with ThreadPoolExecutor(max(1, min(threads, len(names)))) as pool:
        problems = pool.map(lambda n: check_trajectory(root / n, expect)[0], names)
        return {n: p for n, p in zip(names, problems) if p}


def not_whole(root: str | Path, names: list[str], full: set[str], expect: Expect) -> dict[str, str]:
    """name → what is wrong, for the folders of ``names`` that are not whole: the names in ``full``
    are checked in full, the others (checked in full by their scene's job) only for being there
    with their pose file and sidecar."""
    root, out = Path(root), {}
    for name in names:
        if name in full:
            problem = check_trajectory(root / name, expect)[0]
        elif not (root / name).is_dir():
            problem = MISSING
        else:
            absent = [f for f in (TRAJ_DATA, META_NAME) if not (root / name / f).is_file()]
            problem = f"{absent[0]} missing" if absent else None
        if problem:
            out[name] = problem
    return out


def summarise(problems: dict[str, str], shown: int = 3) -> str:
    """``name: problem; name: problem; ... (and N more)`` for a report line."""
    items = [f"{n}: {p}" for n, p in list(problems.items())[:shown]]
    more = len(problems) - shown
    return "; ".join(items) + (f"; and {more} more" if more > 0 else "")


__all__ = ["Expect", "MISSING", "check_trajectory", "damaged", "depth_problem", "image_problem", "jpeg_size", "not_whole",
           "summarise"]
