"""A procedural apartment's colours (`Palette`), drawn from its generator: wood tints, fabrics, paints and fixed
accents, as RGB in 0-255."""
from __future__ import annotations

import colorsys

import numpy as np


def hsv(h, s, v) -> tuple[int, int, int]:
    """The RGB (0-255) of hue ``h`` (turns, wrapped), saturation ``s`` and value ``v`` (0-1)."""
    return tuple(int(round(255 * c)) for c in colorsys.hsv_to_rgb(h % 1.0, s, v))


class Palette:
    """Per-scene colours: a few wood tints, fabrics, paints and fixed accents."""

    def __init__(self, rng: np.random.Generator, height: float):
        self.height = height
        self.woods = [hsv(rng.uniform(0.05, 0.11), rng.uniform(0.35, 0.7), rng.uniform(0.35, 0.95))
                      for _ in range(3)]
        self.fabrics = [hsv(rng.random(), rng.uniform(0.2, 0.7), rng.uniform(0.35, 0.85)) for _ in range(3)]
        self.metal = hsv(0, 0, rng.uniform(0.15, 0.75))
        self.kitchen = hsv(rng.random(), rng.uniform(0.0, 0.4), rng.uniform(0.6, 0.95))
        self.stone = hsv(rng.uniform(0.05, 0.15), rng.uniform(0.0, 0.2), rng.uniform(0.2, 0.9))
        self.appliance = hsv(0, 0, rng.choice([0.85, 0.7, 0.3]))
        self.pot = hsv(rng.uniform(0.0, 0.1), rng.uniform(0.3, 0.7), rng.uniform(0.4, 0.8))
        self.column = hsv(rng.random(), rng.uniform(0.0, 0.15), rng.uniform(0.75, 0.95))
        self.trim = hsv(rng.random(), rng.uniform(0.0, 0.1), rng.uniform(0.85, 1.0))

    def wood(self, rng) -> tuple[int, int, int]:
        return self.woods[int(rng.integers(len(self.woods)))]

    def fabric(self, rng, light: bool = False) -> tuple[int, int, int]:
        if light:
            return hsv(rng.random(), rng.uniform(0.0, 0.2), rng.uniform(0.85, 1.0))
        return self.fabrics[int(rng.integers(len(self.fabrics)))]

    def accent(self, rng) -> tuple[int, int, int]:
        return hsv(rng.random(), rng.uniform(0.3, 0.8), rng.uniform(0.3, 0.9))
