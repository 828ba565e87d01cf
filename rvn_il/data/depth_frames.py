"""Extra frames for the auxiliary depth loss only (``data.depth_root``; off by default, a departure).

The depth head (``model.depth_aux_weight`` > 0, :mod:`rvn_il.models.base`) learns from the current
frames of the expert samples, and an expert keeps its distance from obstacles: on held-out negative
collision frames the head of the small recipe predicts a median clearance of 0.63 m where the rendered
depth has 0.36 m (docs/results/2026-11-25_small_experiment_7). ``data.depth_root`` names a second GNM
dataset with depth sidecars, typically ``rvn-gen dataset=negative dataset.save_depth=true`` on the
training scenes, whose frames run into obstacles. Every training step then also draws
``data.depth_batch`` of its frames (single frames, no context, no goal, no waypoints) and adds their
depth loss, with the same weight, to the step's loss. Nothing else learns from them: the policy still
imitates the expert alone.

Batches (the keys a model's ``forward`` reads, beside the sample dict):
``depth_image`` uint8 [B, 3, H, W] (0-255, scaled by the model) and ``depth_target`` float32 [B, S, S] (metres, 0 where
nothing was hit). Order and resume come from :class:`~rvn_il.data.dataset.EpochSampler` with its own
seed, so a resumed run draws the same frames as an uninterrupted one.
"""
from __future__ import annotations

import numpy as np
import torch
from torch.utils.data import Dataset

from .cache import PackedCache

SEED_TAG = 7  # EpochSampler seed = [seed, SEED_TAG]: an order of its own, independent of the samples'


class DepthFrames(Dataset):
    """Every frame of a packed cache that holds depth maps; ``self[list_of_indices]`` is a whole
    batch (use with ``DataLoader(..., sampler=BatchSampler(EpochSampler(...)), batch_size=None)``)."""

    def __init__(self, cache: PackedCache):
        if not cache.has_depth:
            raise ValueError(f"GNM cache {cache.path} holds no depth maps; data.depth_root needs rvn-gen "
                             "dataset.save_depth=true")
        self.cache = cache
        self.n = int(cache.image_shape[0])
        if self.n == 0:
            raise ValueError(f"data.depth_root: the dataset of {cache.path} has no frames")

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, indices) -> dict[str, torch.Tensor]:
        g = np.asarray(indices, dtype=np.int64).reshape(-1) % self.n
        frames = self.cache.read_frames(g)
        return {"depth_image": torch.from_numpy(np.ascontiguousarray(frames)),  # uint8: scaled by the model
                "depth_target": torch.from_numpy(self.cache.read_depth(g).astype(np.float32))}


def depth_seed(seed: int) -> int:
    """The frame order's seed, derived from the config seed."""
    return int(np.random.SeedSequence([int(seed), SEED_TAG]).generate_state(1)[0])
