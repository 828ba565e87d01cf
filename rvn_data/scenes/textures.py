"""Small tileable procedural textures (uint8 RGB [S, S, 3]) made with numpy from a Generator.

Every texture tiles seamlessly (value noise on a periodic lattice, patterns with whole
periods per image), so UVs in metres divided by the texture's tile size repeat it.
Textures meant to be tinted by vertex colours (paint, fabric, furniture wood) are
near-white; floor textures carry their own colours.
"""
from __future__ import annotations

import numpy as np

SIZE = 64


def value_noise(rng: np.random.Generator, size: int, cells: int, octaves: int = 3) -> np.ndarray:
    """Periodic smooth noise in [0, 1], float64 [size, size]; `cells` lattice cells per side."""
    out = np.zeros((size, size))
    amp, total = 1.0, 0.0
    for o in range(octaves):
        c = cells * 2**o
        if c > size or size % c:
            break
        g = rng.random((c, c))
        t = np.arange(size) * (c / size)
        i0 = np.floor(t).astype(np.int64)
        f = t - i0
        f = f * f * (3.0 - 2.0 * f)
        i1 = (i0 + 1) % c
        fy, fx = f[:, None], f[None, :]
        out += amp * (g[np.ix_(i0, i0)] * (1 - fy) * (1 - fx) + g[np.ix_(i0, i1)] * (1 - fy) * fx
                      + g[np.ix_(i1, i0)] * fy * (1 - fx) + g[np.ix_(i1, i1)] * fy * fx)
        total += amp
        amp *= 0.5
    return out / total


def _to_uint8(img: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def _shade(color: np.ndarray, gain: np.ndarray) -> np.ndarray:
    """Colour (RGB 0..255) times a gain map [S, S] → [S, S, 3]."""
    return np.asarray(color, np.float64)[None, None, :] * gain[..., None]


def wood_planks(rng: np.random.Generator, color, size: int = 128) -> np.ndarray:
    """Floor planks running along u: 8 rows of staggered full-width planks with grain and seams."""
    rows = 8
    rh = size // rows
    v = np.arange(size)
    row = v // rh
    offs = rng.integers(0, size, rows)
    u = (np.arange(size)[None, :] + offs[row][:, None]) % size
    gain = (0.8 + 0.25 * rng.random(rows))[row][:, None] * np.ones((1, size))
    grain = value_noise(rng, size, 4, 2)
    stripes = 0.5 + 0.5 * np.sin(2 * np.pi * ((v % rh)[:, None] * 1.5 / rh + 3.0 * grain))
    gain = gain * (0.9 + 0.1 * stripes) * (0.95 + 0.1 * value_noise(rng, size, 16, 2))
    seam = ((v % rh) == 0)[:, None] | (u == 0)
    gain = np.where(seam, gain * 0.55, gain)
    return _to_uint8(_shade(color, gain))


def floor_tiles(rng: np.random.Generator, color, color2=None, size: int = 128) -> np.ndarray:
    """Square tiles (2 x 2 per image) with grout lines; a checkerboard if `color2` is given."""
    n = 2
    cell = size // n
    i = np.arange(size)
    ti, tj = i[:, None] // cell, i[None, :] // cell
    base = _shade(color, 0.94 + 0.1 * rng.random((n, n))[ti, tj])
    if color2 is not None:
        alt = _shade(color2, 0.94 + 0.1 * rng.random((n, n))[ti, tj])
        base = np.where(((ti + tj) % 2 == 1)[..., None], alt, base)
    base = base * (0.93 + 0.1 * value_noise(rng, size, 8, 3))[..., None]
    grout = ((i % cell) < 2)[:, None] | ((i % cell) < 2)[None, :]
    base = np.where(grout[..., None], np.array([150.0, 148.0, 140.0]) * 0.8, base)
    return _to_uint8(base)


def carpet(rng: np.random.Generator, color, size: int = 64) -> np.ndarray:
    """Carpet: fine fibre noise over soft mottling."""
    fine = rng.random((size, size))
    gain = 0.78 + 0.14 * value_noise(rng, size, 4, 2) + 0.16 * fine
    return _to_uint8(_shade(color, gain))


def paint(rng: np.random.Generator, size: int = SIZE) -> np.ndarray:
    """Near-white painted plaster with subtle noise (tinted by vertex colours)."""
    gain = 0.93 + 0.06 * value_noise(rng, size, 4, 3) + 0.02 * rng.random((size, size))
    return _to_uint8(_shade((255, 255, 255), gain))


def fabric(rng: np.random.Generator, size: int = SIZE) -> np.ndarray:
    """Near-white woven fabric (tinted by vertex colours)."""
    i = np.arange(size)
    weave = np.sin(2 * np.pi * i[:, None] * 16 / size) * np.sin(2 * np.pi * i[None, :] * 16 / size)
    gain = 0.86 + 0.06 * weave + 0.08 * value_noise(rng, size, 8, 2)
    return _to_uint8(_shade((255, 255, 255), gain))


def wood_grain(rng: np.random.Generator, size: int = SIZE) -> np.ndarray:
    """Light furniture wood grain (tinted by vertex colours)."""
    v = np.arange(size)[:, None]
    warp = value_noise(rng, size, 4, 2)
    rings = 0.5 + 0.5 * np.sin(2 * np.pi * (v * 4 / size + 2.5 * warp))
    gain = 0.8 + 0.15 * rings + 0.05 * value_noise(rng, size, 16, 1)
    return _to_uint8(_shade((255, 236, 210), gain))


def foliage(rng: np.random.Generator, size: int = SIZE) -> np.ndarray:
    """Leafy green blotches."""
    n = value_noise(rng, size, 8, 3)
    leaf = np.clip((n - 0.35) * 3.0, 0, 1)
    light = np.array([96.0, 168.0, 72.0])
    dark = np.array([28.0, 70.0, 30.0])
    return _to_uint8(dark + (light - dark) * leaf[..., None])
