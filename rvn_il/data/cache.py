"""Packed HDF5 cache of a GNM split: every frame resized once to the model's image size.

File ``<cache_dir>/<name>_<split>_<W>x<H><suffix>.h5`` (suffix of ``data.crop``: ``_crop`` for
aspect, ``_official`` for official, none for none) holds ``images`` uint8 [N,3,H,W]
(channel-first as the models take them; contiguous, so workers read it through ``np.memmap`` and share the page cache),
``position`` float64 [N,2], ``yaw`` float64 [N], ``traj_index`` int32 [N], ``traj_start`` and
``traj_len`` int64 [M], ``names`` and attributes (fingerprint, spacing, image size). It is
rebuilt when the fingerprint of the source files (names, sizes, mtimes) or the image settings
(size, crop) change, and written atomically (temporary file, then ``os.replace``).
"""
from __future__ import annotations

import logging
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Sequence

import h5py
import numpy as np
from tqdm import tqdm

from rvn_data.atomic import atomic_path

from .gnm import GNMSource, fingerprint
from .images import check_crop, preprocess_image, read_rgb

CACHE_VERSION = 2
SUFFIX = {"aspect": "_crop", "official": "_official", "none": ""}  # one file per crop
log = logging.getLogger(__name__)


def cache_path(source: GNMSource, image_size: Sequence[int], crop: str | bool, cache_dir: str | Path | None) -> Path:
    d = Path(cache_dir) if cache_dir else source.root / ".rvn_cache"
    w, h = int(image_size[0]), int(image_size[1])
    return d / f"{source.name}_{source.split}_{w}x{h}{SUFFIX[check_crop(crop)]}.h5"


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
                fp: str, num_threads: int = 4, progress: bool = True) -> None:
    """Decode, crop, resize and pack every frame of ``source`` into ``path`` (atomic write)."""
    crop = check_crop(crop)
    w, h = int(image_size[0]), int(image_size[1])
    lengths = source.lengths
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    n = int(lengths.sum())
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"cannot create cache folder {path.parent} ({e}); set data.cache_dir= to a writable folder") from None
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            images = f.create_dataset("images", shape=(n, 3, h, w), dtype=np.uint8)  # contiguous
            f["position"] = np.concatenate(source.positions).astype(np.float64)
            f["yaw"] = np.concatenate(source.yaws).astype(np.float64)
            f["traj_index"] = np.repeat(np.arange(len(lengths), dtype=np.int32), lengths)
            f["traj_start"] = starts
            f["traj_len"] = lengths
            f["names"] = np.array(source.names, dtype=h5py.string_dtype())
            f.attrs.update(fingerprint=fp, version=CACHE_VERSION, image_size=[w, h], crop=crop, crop_to_aspect=crop == "aspect",
                           spacing=source.spacing, root=str(source.root), split=source.split, name=source.name)
            with ThreadPoolExecutor(max(1, num_threads)) as pool:
                jobs = pool.map(lambda i: _load_traj_images(source, i, (w, h), crop), range(len(lengths)))
                for i, arr in enumerate(tqdm(jobs, total=len(lengths), desc=f"cache {path.name}", disable=not progress, leave=False)):
                    images[starts[i]:starts[i] + lengths[i]] = arr


def ensure_cache(source: GNMSource, image_size: Sequence[int], crop: str | bool = "aspect",
                 cache_dir: str | Path | None = None, num_threads: int = 4, progress: bool = True) -> Path:
    """Path of an up-to-date cache for ``source`` with frames cropped by ``crop`` (aspect |
    official | none), building it if missing or stale."""
    crop = check_crop(crop)
    path = cache_path(source, image_size, crop, cache_dir)
    fp = fingerprint(source, CACHE_VERSION, tuple(int(s) for s in image_size), _crop_key(crop), source.spacing)
    if _stored_fingerprint(path) != fp:
        log.info("building GNM cache %s from %s (%d trajectories)", path, source.root, len(source.names))
        build_cache(source, path, image_size, crop, fp, num_threads, progress)
    return path


class PackedCache:
    """Read side of the cache. Small arrays are loaded at once; images are opened lazily per
    process (``np.memmap`` on the contiguous HDF5 dataset, h5py as a fallback)."""

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
                self.image_size = tuple(int(v) for v in f.attrs["image_size"])
        except (OSError, KeyError) as e:
            raise ValueError(f"corrupt GNM cache {self.path} ({e}); delete it and it will be rebuilt") from None
        self._images = None
        self._h5 = None

    @property
    def images(self):
        """uint8 [N,3,H,W], opened on first use in this process."""
        if self._images is None:
            with h5py.File(self.path, "r") as f:
                offset = f["images"].id.get_offset()
            if offset is not None:
                self._images = np.memmap(self.path, dtype=np.uint8, mode="r", offset=offset, shape=self.image_shape)
            else:  # empty or non-contiguous dataset
                self._h5 = h5py.File(self.path, "r")
                self._images = self._h5["images"]
        return self._images

    def read_frames(self, index: np.ndarray) -> np.ndarray:
        """Frames ``index`` (any order, repeats allowed) as uint8 [len(index),3,H,W]."""
        images = self.images
        if isinstance(images, np.ndarray):
            return images[index]
        uniq, inverse = np.unique(index, return_inverse=True)  # h5py needs increasing indices
        return images[uniq][inverse]

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_images"] = None
        state["_h5"] = None
        return state
