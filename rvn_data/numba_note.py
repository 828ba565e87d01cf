"""A line for the user when a run is about to compile RVN's numba kernels (the navmesh,
geodesic and ray-casting loops, ``@njit(cache=True)``): on a fresh install that takes 20 s
to about a minute (54 s seen on a busy 2-core machine) before the first progress bar moves, and nothing else would say why. Compiled code is
cached beside the modules (``__pycache__/*.nbi``, ``*.nbc``) or under ``NUMBA_CACHE_DIR``
when set, so the note is printed once per machine (and per Python / numba version)."""
from __future__ import annotations

import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


def kernels_cached() -> bool:
    """True when numba's cache already holds the navmesh kernels of this install."""
    import numba

    cache_dir = str(getattr(numba.config, "CACHE_DIR", "") or "")
    root = Path(cache_dir) if cache_dir else PACKAGE / "navmesh" / "__pycache__"
    pattern = f"kernels.*.py{sys.version_info.major}{sys.version_info.minor}.nbi"
    return root.is_dir() and next(root.rglob(pattern), None) is not None


def note_first_compile(tool: str) -> bool:
    """Print the note when the kernels are not cached yet; returns whether it was printed."""
    if kernels_cached():
        return False
    print(f"{tool}: first run with this install: compiling the numba kernels (20 s to a minute, once; "
          "cached for later runs)", flush=True)
    return True
