"""The one cache root: where RVN keeps what it can rebuild (rvn-train's packed HDF5 frames,
rvn-eval's episode sets, the notebook's clips).

Resolution, first that applies:

1. the setting ``cache_dir=`` of the command (rvn-train, rvn-eval, rvn-rl);
2. the environment variable ``RVN_CACHE_DIR`` (share caches between runs, e.g. on a cluster's
   scratch disk);
3. ``<out_dir>/cache`` of the run;
4. with no run (library calls such as ``make_dataset`` or ``RVNEnv``): a per-user folder in the
   system's temporary directory, and a warning saying so.

Input datasets, the package and the home folder are never written to. Inside the root every
cache has its own folder (``packed/``, ``episodes/``, ``navmesh/``, ``goal_pools/``, ``clips/``), and below that a key
(`settings_key`) of whatever its content depends on, so runs with different settings never
share, or fight over, a file. torch.compile's kernels (``policy.compile``, ``train.compile``) go
to ``<root>/compiled`` (`keep_compiled_kernels`), unless ``TORCHINDUCTOR_CACHE_DIR`` is set.
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Any

ENV = "RVN_CACHE_DIR"
log = logging.getLogger(__name__)
_warned: set[str] = set()


def cache_root(setting: str | os.PathLike | None = None, out_dir: str | os.PathLike | None = None) -> Path:
    """The cache root for a run: ``setting``, else ``$RVN_CACHE_DIR``, else ``<out_dir>/cache``,
    else a per-user temporary folder (with a warning)."""
    if os.environ.get("RVN_EPISODES_DIR") and "RVN_EPISODES_DIR" not in _warned:
        _warned.add("RVN_EPISODES_DIR")
        log.warning("RVN_EPISODES_DIR is no longer read: episode sets go to <cache root>/episodes; set %s", ENV)
    for value in (setting, os.environ.get(ENV)):
        if value not in (None, ""):
            return Path(value).expanduser()
    if out_dir not in (None, ""):
        return Path(out_dir).expanduser() / "cache"
    tmp = Path(tempfile.gettempdir()) / f"rvn-cache-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
    if str(tmp) not in _warned:
        _warned.add(str(tmp))
        log.warning("no cache folder given: caching in %s (set %s or pass cache_dir= to keep caches elsewhere)",
                    tmp, ENV)
    return tmp


KERNELS_ENV = "TORCHINDUCTOR_CACHE_DIR"  # torch.compile's kernel cache (Triton's lies inside it)


def kernels_placed() -> bool:
    """Whether ``TORCHINDUCTOR_CACHE_DIR`` names a folder already: the user's, or one a command set. Torch's
    own default (a temporary folder it writes into the variable once imported) does not count."""
    current = os.environ.get(KERNELS_ENV)
    if not current:
        return False
    if "torch" not in sys.modules:
        return True
    from torch._inductor.runtime.cache_dir_utils import default_cache_dir

    return os.path.abspath(current) != os.path.abspath(default_cache_dir())


def keep_compiled_kernels(root: str | os.PathLike) -> None:
    """torch.compile's kernels (``policy.compile``, ``train.compile``) under ``<root>/compiled`` for this
    process and the workers it starts, unless `kernels_placed` (then they go where they were put)."""
    if not kernels_placed():
        os.environ[KERNELS_ENV] = str(Path(root).expanduser().absolute() / "compiled")


def settings_key(settings: Any, length: int = 12) -> str:
    """Short stable hash of JSON-able ``settings`` (key order does not matter)."""
    text = json.dumps(settings, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:length]


def absolute(path: str | os.PathLike | None) -> str | None:
    """``path`` made absolute (``~`` expanded, symlinks resolved), for use in a key; None stays None."""
    return None if path in (None, "") else str(Path(path).expanduser().resolve())


_unwritable: set[str] = set()  # cache folders already warned about


def cached_file(path: Path, read, build, encode, label: str, what: str, instead: str):
    """``read(path)`` when an earlier ``build()`` left its file there, else ``build()``, written there as
    ``encode(value)`` (atomically: processes that write the same file at once each write it whole). A process that finds
    the file missing builds it under `build_lock`, so processes asking for the same file at once (trainings side by side
    on the same scenes, DD-PPO's ranks, an env's scene prefetch) build it once: the others wait, then read it. A file
    that cannot be read is rebuilt and replaced, with a warning naming it (``label``: what kind of cache file); a folder
    that cannot be written is warned about once (``what`` it would keep, what happens ``instead``) and the value built
    each time."""
    import warnings

    from rvn_data.atomic import write_bytes_atomic

    seen = _identity(path)
    value = _read_kept(path, read, label)
    if value is not _MISSING:
        return value
    with build_lock(path) as locked:
        if locked and _identity(path) != seen:  # another process built it while this one waited
            value = _read_kept(path, read, label)
            if value is not _MISSING:
                return value
        value = build()
        try:
            write_bytes_atomic(path, encode(value))
        except OSError as err:
            if str(path.parent) not in _unwritable:
                _unwritable.add(str(path.parent))
                warnings.warn(f"cannot keep {what} in {path.parent} ({err.strerror or err}); {instead}: set cache_dir= "
                              f"or {ENV} to a writable folder", stacklevel=3)
    return value


_MISSING = object()


def _identity(path: Path) -> tuple | None:
    """(inode, size, mtime) of the file at ``path``, None where there is none: whether it was replaced meanwhile."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


def _read_kept(path: Path, read, label: str):
    """``read(path)``, or `_MISSING` when there is no file, or one that cannot be read (warned about: it is rebuilt)."""
    import warnings
    import zipfile
    import zlib

    if not path.is_file():
        return _MISSING
    try:
        return read(path)
    except (OSError, ValueError, KeyError, TypeError, AttributeError, EOFError, zipfile.BadZipFile, zlib.error) as err:
        warnings.warn(f"{label} cache file {path} is unreadable ({err}); rebuilding it", stacklevel=4)
        return _MISSING


@contextmanager
def build_lock(path: Path):
    """An exclusive lock (``flock``) on ``<path>.lock`` while ``path`` is built; yields whether it holds one. The lock
    file goes once the build is written. Where there is none to be had (no ``fcntl``, a folder that cannot be written,
    a file system without ``flock``), it yields False at once and processes build side by side, as without it. The
    kernel drops the lock of a process that dies, so a killed build never blocks the next."""
    try:
        import fcntl

        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(f"{path}.lock", os.O_RDWR | os.O_CREAT, 0o666)
    except (ImportError, OSError):
        yield False
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            locked = True
        except OSError:
            locked = False
        yield locked
    finally:
        if path.is_file():  # built: a process still waiting holds the old lock file's lock and finds the file
            try:
                os.unlink(f"{path}.lock")
            except OSError:
                pass
        os.close(fd)
