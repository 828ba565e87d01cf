"""Several GNM datasets in one training stream (``data.datasets``): each batch position draws its dataset by
weight, then that dataset's own :class:`EpochSampler` gives the sample, so every dataset keeps its epochs,
goals and seeds as if trained alone.

An index of the mixture is ``sub_index * D + d`` (dataset ``d`` of ``D``; ``sub_index`` as that
dataset's sampler yields it). The dataset of sample position ``p`` of rank ``r`` comes from
``default_rng([seed, MIX_KEY, r, p // BLOCK])``, so the stream is a pure function of the seed and the
position: a resumed run (``start`` = samples already drawn) recounts how many each dataset gave before
``start`` and continues exactly.
"""
from __future__ import annotations

from typing import Iterator, Sequence

import numpy as np
import torch
from torch.utils.data import Sampler

from .dataset import EpochSampler, GNMDataset

MIX_KEY = 0x6D6978  # "mix"
BLOCK = 4096


def dataset_seed(seed: int, d: int) -> int:
    """Dataset ``d``'s seed for its sample order and draws: the run's seed for the first (one dataset trains as
    alone), a derived one for the others (datasets of equal size do not share their orders)."""
    return int(seed) if d == 0 else int(np.random.SeedSequence([int(seed), MIX_KEY, d]).generate_state(1)[0] >> 1)


def mixture_weights(sizes: Sequence[int], weights: Sequence[float | None]) -> np.ndarray:
    """Normalised sampling weights: the given ones, else in proportion to each dataset's samples."""
    w = np.array([float(n) for n in sizes] if all(x is None for x in weights) else [float(x) for x in weights])
    return w / w.sum()


class MixtureDataset:
    """The datasets of ``data.datasets``, read as one (``get_batch`` of mixture indices)."""

    def __init__(self, datasets: Sequence[GNMDataset], weights: Sequence[float | None], names: Sequence[str]):
        self.datasets, self.names = list(datasets), list(names)
        self.weights = mixture_weights([len(d) for d in self.datasets], weights)
        keys = {bool(d.cache.has_depth) for d in self.datasets}
        if len(keys) > 1:
            raise ValueError("data.datasets: some datasets have depth maps and some not; the depth head needs them all")

    @property
    def spacing(self) -> float:  # the first dataset is the deployment robot's
        return self.datasets[0].spacing

    @property
    def cache(self):
        return self.datasets[0].cache

    def __len__(self) -> int:
        return sum(len(d) for d in self.datasets)

    def get_batch(self, indices) -> dict[str, torch.Tensor]:
        index = np.asarray(indices, dtype=np.int64).reshape(-1)
        which, sub = index % len(self.datasets), index // len(self.datasets)
        parts, order = [], []
        for d, ds in enumerate(self.datasets):
            pick = np.flatnonzero(which == d)
            if len(pick):
                parts.append(ds.get_batch(sub[pick]))
                order.append(pick)
        inverse = torch.from_numpy(np.argsort(np.concatenate(order)))
        return {k: torch.cat([p[k] for p in parts])[inverse] for k in parts[0]}

    def delta_range(self, max_samples: int = 100_000, margin: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
        """NoMaD's ``action_stats: auto`` over every dataset (each in its own spacing's units)."""
        ranges = [d.delta_range(max_samples, margin) for d in self.datasets]
        return np.min([r[0] for r in ranges], axis=0), np.max([r[1] for r in ranges], axis=0)

    def sampler(self, seed: int, rank: int = 0, world: int = 1, start: int = 0) -> "MixtureSampler":
        return MixtureSampler([len(d) for d in self.datasets], self.weights, seed, rank, world, start)


class MixtureSampler(Sampler[int]):
    """Endless, seeded, resumable sampler of mixture indices (module docstring)."""

    def __init__(self, sizes: Sequence[int], weights: np.ndarray, seed: int = 0, rank: int = 0, world: int = 1,
                 start: int = 0):
        self.sizes, self.weights = [int(n) for n in sizes], np.asarray(weights, dtype=np.float64)
        self.seed, self.rank, self.world, self.start = int(seed), int(rank), int(world), int(start)
        for n in self.sizes:
            if n // self.world == 0:
                raise ValueError(f"a dataset of {n} samples is smaller than the {world} ranks")

    def _choices(self, block: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, MIX_KEY, self.rank, block])
        return rng.choice(len(self.sizes), BLOCK, p=self.weights)

    def __iter__(self) -> Iterator[int]:
        D = len(self.sizes)
        block, offset = divmod(self.start, BLOCK)
        drawn = np.zeros(D, dtype=np.int64)
        for b in range(block):
            drawn += np.bincount(self._choices(b), minlength=D)
        drawn += np.bincount(self._choices(block)[:offset], minlength=D)
        streams = [iter(EpochSampler(n, dataset_seed(self.seed, d), self.rank, self.world, int(k)))
                   for d, (n, k) in enumerate(zip(self.sizes, drawn))]
        while True:
            for d in self._choices(block)[offset:].tolist():
                yield next(streams[d]) * D + d
            block, offset = block + 1, 0

    def __len__(self) -> int:  # one pass over every dataset's samples
        return sum(n // self.world for n in self.sizes)
