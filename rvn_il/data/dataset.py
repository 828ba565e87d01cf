"""Torch dataset over a packed GNM cache, sampling as visualnav-transformer's ViNT_Dataset.

For a current frame ``t`` of a trajectory of length L (last usable frame ``e = L-1-end_slack``):
``t`` ranges over ``[context_size, e - goal_offset[0]]``; the context is frames
``t-context_size .. t`` (oldest first); the goal is frame ``t+k`` with ``k`` uniform in
``[goal_offset[0], min(goal_offset[1], e-t)]``; the ``len_traj_pred`` waypoints are the poses of
frames ``t+1 .. t+len_traj_pred`` (past the trajectory end the last pose is repeated), all
expressed in the frame of pose ``t`` (x forward, y left) and divided by
``metric_waypoint_spacing``. Unlike the official code the last ``len_traj_pred`` frames are
kept (padded), so short negative trajectories still yield their collision steps.
With ``waypoint_frames="moving"`` (``data.waypoint_frames``; a departure from GNM, off by default) the
waypoints are the poses of the next ``len_traj_pred`` frames whose position differs from the frame
before (turns in place skipped): a discrete-action expert turns in place on ~45 % of its steps, so
the GNM labels mix zero-displacement waypoints of varying count into the path; the moving labels are
the path itself, and the first of them is the point the expert moves to next (what the action
adapter steers to), whether or not it turns first.
With ``pad_context=True`` (``data.pad_context``; a departure from GNM, off by default) ``t`` starts at 0
and context frames before the trajectory's first repeat frame 0, as the policy fills its context after
``reset()``: GNM never trains the first ``context_size`` decisions of a trajectory, which are an
episode's first decisions at deployment (where the expert mostly turns in place to face its path).
``obs_image`` is uint8 (0-255, a quarter of float32's bytes through the loader's workers, pinned memory
and the copy to a GPU); the model scales it to [0, 1] (:meth:`PointGoalModel.encode_frames`).
When the cache holds depth maps (``model.depth_aux_weight`` > 0) an item also has ``depth``
float32 [S,S], the current frame's (metres, 0 where nothing was hit).
Each item's randomness comes from ``default_rng([seed, index])``; indices past ``len(self)``
(see :class:`EpochSampler`) give fresh draws for later epochs.
With ``frame_stride`` s > 1 (a dataset's ``waypoint_spacing``, as the official loader's) context frames,
waypoints and goal steps are s frames apart and the labels are divided by s x metric_waypoint_spacing
(``self.spacing``): data recorded at a finer spacing than the robot's step keeps the robot's units.
"""
from __future__ import annotations

from typing import Iterator, Sequence

import numpy as np
import torch
from torch.utils.data import Dataset, Sampler, get_worker_info

from rvn_data.conventions import to_local

from .cache import PackedCache


WAYPOINT_FRAMES = ("all", "moving")
MOVE_EPS = 1e-6  # m: a frame "moved" when its position is farther than this from the previous frame's


def check_waypoint_frames(value: object) -> str:
    """``data.waypoint_frames`` as one of :data:`WAYPOINT_FRAMES`; a ValueError naming it otherwise."""
    if value not in WAYPOINT_FRAMES:
        raise ValueError(f"data.waypoint_frames={value!r}: choose all (the poses of frames t+1..t+len_traj_pred, GNM's)"
                         f" or moving (the next len_traj_pred frames where the robot moved; turns in place skipped)")
    return str(value)


def moved_frames(position: np.ndarray) -> np.ndarray:
    """Global indices of the frames reached by a move (position [N,2] of the whole cache; seams
    between trajectories count too, the caller clips to each trajectory's end), then a sentinel
    past every frame."""
    step = np.linalg.norm(np.diff(position, axis=0), axis=1)
    return np.append(np.flatnonzero(step > MOVE_EPS) + 1, np.iinfo(np.int64).max)


class GNMDataset(Dataset):
    """Items are the sample dict of docs/ARCHITECTURE.md."""

    def __init__(self, cache: PackedCache, context_size: int, len_traj_pred: int,
                 goal_offset: Sequence[int] = (1, 20), goal_mask_prob: float = 0.0,
                 end_slack: int = 0, seed: int = 0, skip_short: bool = False, waypoint_frames: str = "all",
                 pad_context: bool = False, frame_stride: int = 1):
        self.waypoint_frames = check_waypoint_frames(waypoint_frames)
        self.stride = int(frame_stride)
        if self.stride < 1 or (self.stride > 1 and self.waypoint_frames == "moving"):
            raise ValueError(f"waypoint_spacing={frame_stride}: give a whole number >= 1 (1 with data.waypoint_frames=moving)")
        lo, hi = int(goal_offset[0]), int(goal_offset[1])
        if not 1 <= lo <= hi:
            raise ValueError(f"data.goal_offset={list(goal_offset)} must satisfy 1 <= min <= max")
        if not 0.0 <= goal_mask_prob <= 1.0:
            raise ValueError(f"goal_mask_prob={goal_mask_prob} must be in [0, 1]")
        self.cache, self.context_size, self.len_traj_pred = cache, int(context_size), int(len_traj_pred)
        self.goal_offset, self.goal_mask_prob, self.seed = (lo, hi), float(goal_mask_prob), int(seed)
        self.spacing = cache.spacing * self.stride
        self.skipped: list[str] = []  # trajectories too short for the context and the first goal (skip_short)
        curr, last = [], []
        for j, (start, length) in enumerate(zip(cache.traj_start, cache.traj_len)):
            e = int(length) - 1 - int(end_slack)
            first, final = (0 if pad_context else self.context_size * self.stride), e - lo * self.stride
            if final < first:
                if skip_short:
                    self.skipped.append(cache.names[j])
                    continue
                need = ("" if pad_context else "context_size+") + "1+goal_offset[0]+end_slack"
                if self.stride > 1:
                    need = ("" if pad_context else "context_size*s+") + "1+goal_offset[0]*s+end_slack (s: waypoint_spacing)"
                raise ValueError(
                    f"trajectory {cache.names[j]!r} ({cache.path}) has {length} frames, fewer than {need} = "
                    f"{first + 1 + lo * self.stride + end_slack}; remove it or set data.skip_short=true")
            ts = np.arange(first, final + 1)
            curr.append(start + ts)
            last.append(np.full(len(ts), start + e))
        if not curr:
            raise ValueError(f"no trajectory in {cache.path} is long enough for context_size={self.context_size}")
        self.curr = np.concatenate(curr).astype(np.int64)  # global frame index of the current frame
        self.last = np.concatenate(last).astype(np.int64)  # global index of the last usable frame
        self.start = cache.traj_start[cache.traj_index[self.curr]]  # global index of the trajectory's frame 0
        self.end = self.start + cache.traj_len[cache.traj_index[self.curr]] - 1
        self.moved = moved_frames(cache.position) if self.waypoint_frames == "moving" else None

    def __len__(self) -> int:
        return len(self.curr)

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        return {k: v[0] for k, v in self.get_batch([index]).items()}

    def get_batch(self, indices) -> dict[str, torch.Tensor]:
        """The items of ``indices`` already stacked (one vectorised read; same values as
        ``__getitem__``)."""
        index = np.asarray(indices, dtype=np.int64).reshape(-1)
        n = index % len(self.curr)
        g, e = self.curr[n], self.last[n]
        lo, hi = self.goal_offset
        ks, masked = np.empty(len(n), np.int64), np.zeros(len(n), np.float32)
        for j, (i, top) in enumerate(zip(index.tolist(), np.minimum(hi, (e - g) // self.stride).tolist())):
            rng = np.random.default_rng([self.seed, i])
            ks[j] = rng.integers(lo, top + 1)
            masked[j] = self.goal_mask_prob > 0 and rng.random() < self.goal_mask_prob
        context = np.maximum(g[:, None] + np.arange(-self.context_size, 1) * self.stride, self.start[n][:, None])  # pad: frame 0
        frames = self.cache.read_frames(context.ravel())
        obs = torch.from_numpy(np.ascontiguousarray(frames)).view(len(n), self.context_size + 1, *frames.shape[1:])
        actions = self.waypoints(n)
        pos, yaw = self.cache.position, self.cache.yaw[g]
        goal = to_local(pos[g + ks * self.stride][:, None], pos[g][:, None], yaw[:, None])[:, 0] / self.spacing
        images = torch.empty(obs.shape, dtype=torch.uint8)  # 0-255: the model scales them on its device
        if get_worker_info() is not None:  # built in shared memory: the main process maps it, no copy
            images.share_memory_()
        out = {
            "obs_image": images.copy_(obs),
            "goal_pos": torch.from_numpy(goal.astype(np.float32)),
            "actions": torch.from_numpy(actions.astype(np.float32)),
            "distance": torch.from_numpy(ks),
            "goal_mask": torch.from_numpy(masked),
            "action_mask": torch.ones(len(n), dtype=torch.float32),
        }
        if self.cache.has_depth:
            out["depth"] = torch.from_numpy(self.cache.read_depth(g).astype(np.float32))
        return out

    def waypoints(self, n: np.ndarray) -> np.ndarray:
        """Normalised future waypoints [len(n), len_traj_pred, 2] of samples ``n`` (< len(self))."""
        g = self.curr[n]
        if self.moved is not None:
            picks = np.searchsorted(self.moved, g, side="right")[:, None] + np.arange(self.len_traj_pred)
            future = self.moved[np.minimum(picks, len(self.moved) - 1)]  # the last entry: past every move
        else:
            future = g[:, None] + np.arange(1, self.len_traj_pred + 1) * self.stride
        future = np.minimum(future, self.end[n][:, None])  # past the trajectory's end: its last pose
        pos = self.cache.position
        return to_local(pos[future], pos[g][:, None], self.cache.yaw[g][:, None]) / self.spacing

    def delta_range(self, max_samples: int = 100_000, margin: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
        """Per-axis (min, max) of the waypoint deltas (NoMaD's ``action_stats: auto``), widened
        by ``margin`` of the span; computed on up to ``max_samples`` evenly spaced samples."""
        n = np.unique(np.linspace(0, len(self) - 1, min(len(self), max_samples)).astype(np.int64))
        wp = self.waypoints(n)
        deltas = np.diff(wp, axis=1, prepend=np.zeros_like(wp[:, :1])).reshape(-1, 2)
        lo, hi = deltas.min(0), deltas.max(0)
        pad = np.maximum(hi - lo, 1e-3) * margin
        return lo - pad, hi + pad


class BatchView(Dataset):
    """``BatchView(ds)[list_of_indices]`` = ``ds.get_batch(...)``: use with
    ``DataLoader(BatchView(ds), sampler=BatchSampler(...), batch_size=None)`` so workers build
    whole batches (no per-item Python work or collation copy)."""

    def __init__(self, dataset: GNMDataset):
        self.dataset = dataset

    def __len__(self) -> int:
        return len(self.dataset)

    def __getitem__(self, indices) -> dict[str, torch.Tensor]:
        return self.dataset.get_batch(indices)


class EpochSampler(Sampler[int]):
    """Endless, seeded, resumable sampler: epoch ``e`` is ``default_rng([seed, e])``'s permutation
    of the dataset, sharded over ``world_size`` ranks; yields ``e*len + i`` so items of later
    epochs draw new goals and masks. ``start`` skips that many of this rank's samples (resume)."""

    def __init__(self, n: int, seed: int = 0, rank: int = 0, world_size: int = 1, start: int = 0):
        self.n, self.seed, self.rank, self.world, self.start = int(n), int(seed), int(rank), int(world_size), int(start)
        self.per_rank = self.n // self.world
        if self.per_rank == 0:
            raise ValueError(f"dataset of {n} samples is smaller than the {world_size} ranks")

    def __iter__(self) -> Iterator[int]:
        epoch, skip = divmod(self.start, self.per_rank)
        while True:
            perm = np.random.default_rng([self.seed, epoch]).permutation(self.n)
            shard = perm[self.rank::self.world][:self.per_rank]
            for i in shard[skip:]:
                yield int(epoch * self.n + i)
            skip, epoch = 0, epoch + 1

    def __len__(self) -> int:  # one epoch's worth; the iterator itself never ends
        return self.per_rank
