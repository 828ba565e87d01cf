"""Packed HDF5 cache of a GNM split: every frame resized once to the model's image size.

File ``<cache_dir>/<key>/<name>_<split>_<W>x<H><suffix>.h5`` (suffix of ``data.crop``: ``_crop``
for aspect, ``_official`` for official, none for none; ``<key>`` a hash of the dataset's identity,
its absolute root, name, split and trajectory list, and of the cache settings, so different
datasets, splits or settings never share a file; ``cache_dir`` is ``data.cache_dir``, by default ``<cache root>/packed``, see
`rvn_data.cache_root`; the dataset folder itself is only read) holds ``images`` uint8 [N,3,H,W]
(channel-first as the models take them; contiguous, so workers read it through ``np.memmap`` and share the page cache),
``position`` float64 [N,2], ``yaw`` float64 [N], ``traj_index`` int32 [N], ``traj_start`` and
``traj_len`` int64 [M], ``names`` and attributes (fingerprint, spacing, image size). It is
rebuilt when the fingerprint of the source files (names, sizes, mtimes) or the image settings
(size, crop) change, and written atomically (temporary file, then ``os.replace``).

With depth (``model.depth_aux_weight`` > 0, see :mod:`.depth`) the file is another one
(``..._depth<S>.h5``, its own fingerprint) that also holds ``depth`` float16 [N,S,S] (metres,
0 = nothing hit) from the trajectories' ``depth.npy`` sidecars.
"""
from __future__ import annotations

import hashlib
import logging
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Sequence

import h5py
import numpy as np
from tqdm import tqdm

from rvn_data.atomic import atomic_path
from rvn_data.cache_root import absolute, cache_root, settings_key
from rvn_data.dataset.reader import GNMSource, read_rgb

from .depth import load_traj_depth, require_depth
from .images import check_crop, preprocess_image

CACHE_VERSION = 2
SUFFIX = {"aspect": "_crop", "official": "_official", "none": ""}  # one file per crop
log = logging.getLogger(__name__)


def fingerprint(source: GNMSource, *extra: object) -> str:
    """Hash of every file name, size and mtime in the split's folders, plus ``extra`` settings."""
    h = hashlib.sha256(repr(extra).encode())
    for n in source.names:
        entries = sorted((e.name, e.stat().st_size, e.stat().st_mtime_ns) for e in os.scandir(source.root / n) if e.is_file())
        h.update(n.encode())
        h.update(repr(entries).encode())
    return h.hexdigest()[:32]


def cache_path(source: GNMSource, image_size: Sequence[int], crop: str | bool, cache_dir: str | Path | None,
               depth: int | None = None) -> Path:
    """Where the cache of ``source`` with these settings lives (``cache_dir`` None: the cache root's
    ``packed/`` folder, `rvn_data.cache_root.cache_root`)."""
    crop = check_crop(crop)
    d = Path(cache_dir).expanduser() if cache_dir else cache_root() / "packed"
    w, h = int(image_size[0]), int(image_size[1])
    key = settings_key({"root": absolute(source.root), "name": source.name, "split": source.split,
                        "trajectories": settings_key(source.names, 32), "version": CACHE_VERSION, "image_size": [w, h], "crop": crop,
                        "depth": int(depth) if depth else None, "spacing": source.spacing})
    extra = f"_depth{int(depth)}" if depth else ""
    return d / key / f"{source.name}_{source.split}_{w}x{h}{SUFFIX[crop]}{extra}.h5"


def _crop_key(crop: str) -> object:
    """The crop as it enters the fingerprint: the former boolean for aspect/none (caches built
    before the official crop stay valid), the name otherwise."""
    return {"aspect": True, "none": False}.get(crop, crop)


def _stored_fingerprint(path: Path) -> str | None:
    try:
        with h5py.File(path, "r") as f:
            return str(f.attrs.get("fingerprint", ""))
    except OSError:
        return None  # missing or truncated: rebuild


def _load_traj_images(source: GNMSource, i: int, image_size, crop: str) -> np.ndarray:
    frames = [preprocess_image(read_rgb(source.frame_path(i, t)), image_size, crop) for t in range(len(source.positions[i]))]
    return np.stack(frames).transpose(0, 3, 1, 2)  # [T,3,H,W]


def build_cache(source: GNMSource, path: Path, image_size: Sequence[int], crop: str | bool,
                fp: str, num_threads: int = 4, progress: bool = True, depth: int | None = None) -> None:
    """Decode, crop, resize and pack every frame of ``source`` into ``path`` (atomic write); with
    ``depth`` = S also the [S,S] depth maps of every frame."""
    crop = check_crop(crop)
    w, h = int(image_size[0]), int(image_size[1])
    lengths = source.lengths
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    n = int(lengths.sum())
    if depth:
        require_depth(source)  # every sidecar is there before any frame is decoded
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"cannot create cache folder {path.parent} ({e}); set cache_dir= or RVN_CACHE_DIR "
                         "to a writable folder") from None
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            images = f.create_dataset("images", shape=(n, 3, h, w), dtype=np.uint8)  # contiguous
            f["position"] = np.concatenate(source.positions).astype(np.float64)
            f["yaw"] = np.concatenate(source.yaws).astype(np.float64)
            f["traj_index"] = np.repeat(np.arange(len(lengths), dtype=np.int32), lengths)
            f["traj_start"] = starts
            f["traj_len"] = lengths
            f["names"] = np.array(source.names, dtype=h5py.string_dtype())
            if depth:
                depths = f.create_dataset("depth", shape=(n, depth, depth), dtype=np.float16)  # contiguous
                f.attrs["depth_size"] = int(depth)
            f.attrs.update(fingerprint=fp, version=CACHE_VERSION, image_size=[w, h], crop=crop, crop_to_aspect=crop == "aspect",
                           spacing=source.spacing, root=str(source.root), split=source.split, name=source.name)
            with ThreadPoolExecutor(max(1, num_threads)) as pool:
                jobs = pool.map(lambda i: _load_traj_images(source, i, (w, h), crop), range(len(lengths)))
                for i, arr in enumerate(tqdm(jobs, total=len(lengths), desc=f"cache {path.name}", disable=not progress, leave=False)):
                    images[starts[i]:starts[i] + lengths[i]] = arr
                    if depth:
                        depths[starts[i]:starts[i] + lengths[i]] = load_traj_depth(source, i, depth)


def ensure_cache(source: GNMSource, image_size: Sequence[int], crop: str | bool = "aspect",
                 cache_dir: str | Path | None = None, num_threads: int = 4, progress: bool = True,
                 depth: int | None = None) -> Path:
    """Path of an up-to-date cache for ``source`` with frames cropped by ``crop`` (aspect |
    official | none), and [depth, depth] depth maps unless ``depth`` is None, building it if
    missing or stale."""
    crop = check_crop(crop)
    path, fp, current = cache_state(source, image_size, crop, cache_dir, depth)
    if not current:
        log.info("building GNM cache %s from %s (%d trajectories)", path, source.root, len(source.names))
        build_cache(source, path, image_size, crop, fp, num_threads, progress, depth)
    return path


def cache_state(source: GNMSource, image_size: Sequence[int], crop: str | bool = "aspect",
                cache_dir: str | Path | None = None, depth: int | None = None) -> tuple[Path, str, bool]:
    """(path, fingerprint, whether the cache there is current): current means it was packed from exactly these
    files (names, sizes, modification times) with these settings, so they were whole when it was built and
    have not changed since (rvn-train's preflight then need not read every frame again)."""
    crop = check_crop(crop)
    path = cache_path(source, image_size, crop, cache_dir, depth)
    extra = (("depth", int(depth)),) if depth else ()  # caches without depth keep their fingerprint
    fp = fingerprint(source, CACHE_VERSION, tuple(int(s) for s in image_size), _crop_key(crop), source.spacing, *extra)
    return path, fp, _stored_fingerprint(path) == fp


class PackedCache:
    """Read side of the cache. Small arrays are loaded at once; images (and depth maps) are
    opened lazily per process (``np.memmap`` on the contiguous HDF5 dataset, h5py as a fallback)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        try:
            with h5py.File(self.path, "r") as f:
                self.position = f["position"][:]
                self.yaw = f["yaw"][:]
                self.traj_index = f["traj_index"][:]
                self.traj_start = f["traj_start"][:]
                self.traj_len = f["traj_len"][:]
                self.names = [s.decode() if isinstance(s, bytes) else str(s) for s in f["names"][:]]
                self.image_shape = tuple(f["images"].shape)
                self.spacing = float(f.attrs["spacing"])
                self.name = str(f.attrs.get("name", "")) or None  # the dataset's name in data_splits
                self.image_size = tuple(int(v) for v in f.attrs["image_size"])
                self.depth_shape = tuple(f["depth"].shape) if "depth" in f else None
        except (OSError, KeyError) as e:
            raise ValueError(f"corrupt GNM cache {self.path} ({e}); delete it and it will be rebuilt") from None
        self._arrays: dict = {}
        self._h5 = None

    @property
    def has_depth(self) -> bool:
        return self.depth_shape is not None

    def _open(self, key: str, dtype, shape: tuple):
        """Dataset ``key`` of the file, opened on first use in this process."""
        if key not in self._arrays:
            with h5py.File(self.path, "r") as f:
                offset = f[key].id.get_offset()
            if offset is not None:
                self._arrays[key] = np.memmap(self.path, dtype=dtype, mode="r", offset=offset, shape=shape)
            else:  # empty or non-contiguous dataset
                if self._h5 is None:
                    self._h5 = h5py.File(self.path, "r")
                self._arrays[key] = self._h5[key]
        return self._arrays[key]

    @property
    def images(self):
        """uint8 [N,3,H,W], opened on first use in this process."""
        return self._open("images", np.uint8, self.image_shape)

    @staticmethod
    def _read(array, index: np.ndarray) -> np.ndarray:
        if isinstance(array, np.ndarray):
            return array[index]
        uniq, inverse = np.unique(index, return_inverse=True)  # h5py needs increasing indices
        return array[uniq][inverse]

    def read_frames(self, index: np.ndarray) -> np.ndarray:
        """Frames ``index`` (any order, repeats allowed) as uint8 [len(index),3,H,W]."""
        return self._read(self.images, index)

    def read_depth(self, index: np.ndarray) -> np.ndarray:
        """Depth maps of frames ``index`` as float16 [len(index),S,S] (metres, 0 = nothing hit)."""
        if self.depth_shape is None:
            raise ValueError(f"GNM cache {self.path} holds no depth maps")
        return self._read(self._open("depth", np.float16, self.depth_shape), index)

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_arrays"] = {}
        state["_h5"] = None
        return state
