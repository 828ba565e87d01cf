"""Policies of the benchmark contract (docs/ARCHITECTURE.md): ``reset()`` and
``act(obs) -> int`` with ``obs = {'rgb': uint8 [H,W,3], 'pointgoal': float32 [2]}``.

Each decision: the current frame is preprocessed exactly as in training
(:func:`rvn_il.data.images.preprocess_image` with the member's crop, the ``data.crop`` its
checkpoint was trained with), encoded once and pushed onto a queue of the
last C+1 per-frame tokens (filled with the first frame after ``reset()``; tokens are cached, so
each frame goes through EfficientNet once); the point goal is divided by
metric_waypoint_spacing; the model predicts waypoints which, back in metres, become an action
through :mod:`rvn_il.policies.control`. Sampling uses a torch Generator re-seeded with ``seed``
in every ``reset()``, so an episode's actions do not depend on which episodes ran before.

On a CPU a decision runs with at most ``threads`` torch intra-op threads (default 1; None keeps
torch's setting): one frame and a few small denoiser batches gain little from more, and on a
machine whose cores are busy, threads that wait for each other at every operation make a
decision many times slower.
"""
from __future__ import annotations

import math
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import torch

from rvn_data.conventions import Action, StopRule

from ..data.images import check_crop, preprocess_image
from ..models import PointGoalModel
from .control import ControlConfig, waypoints_to_action
from .cor import SELECTIONS, rms_distance, select_expert
from .depth_veto import DepthVeto, Floor, check_depth_veto, clearance, predicted_depth, turn_instead
from .escape import Escape
from .turn_commit import TurnCommit


@contextmanager
def intra_op_threads(n: int | None):
    """torch's intra-op thread count lowered to ``n`` inside the block (unchanged for None)."""
    old = torch.get_num_threads()
    if n is None or n >= old:
        yield
        return
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(old)


@dataclass
class Member:
    """One network of a policy with its normalisation statistics."""

    model: PointGoalModel
    spacing: float  # metric_waypoint_spacing of its training data, metres
    crop: str = "aspect"  # data.crop of its training data: aspect | official | none (True/False: aspect/none)
    hfov_deg: float | None = None  # camera hfov of its training data, degrees (None: not recorded)
    datasets: tuple[str, ...] = ()  # the dataset folders it trained on (stats.json), for rvn-eval's trained_scenes

    def __post_init__(self):
        self.crop = check_crop(self.crop, "policy member crop")


class PointGoalPolicy:
    """ViNT-/NoMaD-PointGoal policy over ``num_samples`` predicted trajectories: ``aggregate``
    ``first`` follows sample 0 (as NoMaD's deployment code); ``vote`` turns every sample into
    an action and takes the most frequent one (ties: the earliest sample's), which cancels the
    sampling noise of an under-trained diffusion head while keeping a multi-modal choice (left or
    right around an obstacle) whole, where the mean trajectory would run between the two; ``medoid``
    follows the sample nearest the others (RMS distance, :func:`.cor.rms_distance`): NoMaD-Neg's CoR without
    its negative term, the control that tells what the negatives add to NoMaD-Neg's choice.
    With several members (``policy.ensemble``), ``vote`` pools every member's samples, member 0's first.
    ``depth_veto`` (metres with the band rule, a :class:`DepthVeto`, or None: off): turn instead of a
    MOVE_FORWARD that member 0's depth head sees blocked (:mod:`.depth_veto`); ``vetoes`` counts them since ``reset()``.
    ``escape`` (:mod:`.escape`) and ``turn_commit`` (:mod:`.turn_commit`): departures for stalls, off (None) by default.
    ``episode_stats()`` (recorded by rvn-eval in each episode's ``policy_stats``): ``decisions`` (model
    calls since ``reset()``), ``vetoes``, and what a subclass adds. ``embodiment``: the robot and camera of
    its training data (`rvn_data.embodiment`; None: not recorded), which rvn-eval compares with its own."""

    AGGREGATES = ("first", "vote", "medoid")
    embodiment: dict | None = None

    def __init__(self, members: list[Member], control: ControlConfig, num_samples: int = 8, seed: int = 0,
                 device: str | torch.device = "cpu", aggregate: str = "first", threads: int | None = 1,
                 depth_veto: float | DepthVeto | None = None, escape: Escape | None = None, floor: Floor | None = None,
                 turn_commit: TurnCommit | None = None):
        if aggregate not in self.AGGREGATES:
            raise ValueError(f"policy aggregate={aggregate!r}; choose one of {self.AGGREGATES}")
        if threads is not None and not (isinstance(threads, int) and threads >= 1):
            raise ValueError(f"policy threads={threads!r}; give a positive integer or null (torch's setting)")
        self.aggregate, self.threads = aggregate, threads
        self.members, self.control = members, control
        self.num_samples, self.seed, self.device = int(num_samples), int(seed), torch.device(device)
        self.depth_veto = check_depth_veto(depth_veto, bool(members) and members[0].model.depth_head is not None)
        self.escape, self.turn_commit = escape, turn_commit
        self.floor = floor  # the veto and the escape look past the bare floor the depth grid's lower rows see
        self.last_waypoints: np.ndarray | None = None  # metres, robot frame (for plots/debugging)
        self.stop = StopRule(control.stop_radius, control.theta_step)
        self.reset()

    def reset(self) -> None:
        self.queues = [deque(maxlen=m.model.context_size + 1) for m in self.members]
        self.generator = torch.Generator(device=self.device).manual_seed(self.seed)
        self.vetoes = 0
        self.decisions = 0
        self.stop.reset()
        if self.escape is not None:
            self.escape.reset()
        if self.turn_commit is not None:
            self.turn_commit.reset()

    def episode_stats(self) -> dict[str, int]:
        stats = {"decisions": self.decisions, "vetoes": self.vetoes}
        if self.escape is not None:
            stats["escapes"] = self.escape.escapes
        if self.turn_commit is not None:
            stats["commits"] = self.turn_commit.commits
        return stats

    def _push(self, rgb: np.ndarray) -> list[torch.Tensor]:
        """Encode the frame for every member; return each member's context tokens [1,C+1,D].
        Members with the same image size and crop share the preprocessed frame."""
        out, frames = [], {}
        for m, q in zip(self.members, self.queues):
            key = (tuple(m.model.image_size), m.crop)
            if key not in frames:
                img = preprocess_image(rgb, m.model.image_size, m.crop)
                frames[key] = torch.from_numpy(img).to(self.device).permute(2, 0, 1).unsqueeze(0).float().div_(255.0)
            tok = m.model.encode_frames(frames[key], fast=True)[0]
            while len(q) < q.maxlen - 1:  # first frame after reset fills the context
                q.append(tok)
            q.append(tok)
            out.append(torch.stack(list(q)).unsqueeze(0))
        return out

    def sample(self, tokens: list[torch.Tensor], pointgoal: np.ndarray) -> list[np.ndarray]:
        """Every member's predicted trajectories in metres: [S,len,2] each."""
        out = []
        for m, tok in zip(self.members, tokens):
            goal = torch.as_tensor(np.asarray(pointgoal, np.float32) / m.spacing, device=self.device).unsqueeze(0)
            wp = m.model.predict(tok, goal, self.num_samples, self.generator)[0]
            out.append(wp.double().cpu().numpy() * m.spacing)
        return out

    def choose(self, samples: list[np.ndarray], pointgoal: np.ndarray) -> np.ndarray:
        """The trajectory to follow: ``first``, member 0's sample 0; ``vote``, of all members' samples [S,len,2]."""
        if self.aggregate == "first":
            return samples[0][0]
        pooled = [wp for member in samples for wp in member]
        if self.aggregate == "medoid":  # CoR's expert term alone: nearest the other samples (rms_distance)
            if len(pooled) == 1:  # ViNT's one prediction, or num_samples=1: nothing to be near
                return pooled[0]
            stack = torch.as_tensor(np.stack(pooled))
            return pooled[int(torch.argmin(rms_distance(stack, stack, exclude_self=True)))]
        actions = [int(waypoints_to_action(wp, pointgoal, self.control)) for wp in pooled]
        counts = np.bincount(actions, minlength=len(Action))
        best = max(actions, key=lambda a: (counts[a], -actions.index(a)))
        return pooled[actions.index(best)]

    @staticmethod
    def _check(obs) -> tuple[np.ndarray, np.ndarray]:
        try:
            rgb, pointgoal = obs["rgb"], np.asarray(obs["pointgoal"], dtype=np.float64).reshape(-1)
        except (KeyError, TypeError) as e:
            raise ValueError(f"policy observation must be a dict with 'rgb' and 'pointgoal' ({e!r})") from None
        if pointgoal.shape != (2,) or not np.isfinite(pointgoal).all():
            raise ValueError(f"obs['pointgoal'] must be 2 finite numbers (x forward, y left), got {obs['pointgoal']!r}")
        return np.asarray(rgb), pointgoal

    def act(self, obs) -> int:
        rgb, pointgoal = self._check(obs)
        with torch.inference_mode(), intra_op_threads(self.threads if self.device.type == "cpu" else None):
            tokens = self._push(rgb)
            near = self.stop.act(pointgoal)  # within stop_radius: STOP (a step on after one the env did not count)
            if near is not None:
                if self.turn_commit is not None:
                    self.turn_commit.taken(int(near))
                return int(near)
            samples = self.sample(tokens, pointgoal)
            self.decisions += 1
            self.last_waypoints = self.choose(samples, pointgoal)
            action = int(waypoints_to_action(self.last_waypoints, pointgoal, self.control))
            head = self.members[0].model.depth_head
            depth = None
            if head is not None and (self.escape is not None or (action == Action.MOVE_FORWARD and self.depth_veto)):
                depth = predicted_depth(head, tokens[0][0, -1])
            standing = depth if depth is None or self.floor is None else self.floor.standing(depth)
            blocked = self.depth_veto is not None and depth is not None and self.depth_veto.blocked(standing)
            if action == Action.MOVE_FORWARD and blocked:
                self.vetoes += 1
                actions = [int(waypoints_to_action(wp, pointgoal, self.control)) for wp in samples[0]]
                action = turn_instead(actions, depth)
            if self.turn_commit is not None:
                action = self.turn_commit.act(action)
            if self.escape is not None:
                free = None if depth is None else clearance(standing)
                action = self.escape.act(action, math.atan2(pointgoal[1], pointgoal[0]), free, blocked)
            if self.turn_commit is not None:
                self.turn_commit.taken(action)
        return action


class NoMaDNegPolicy(PointGoalPolicy):
    """NoMaD-Neg: k samples from NoMaD_e (member 0) and NoMaD_n (member 1); follow the expert
    sample selected by CoR (``selection`` argmax | argmin, Student-t parameter ``cor_alpha``)."""

    def __init__(self, members: list[Member], control: ControlConfig, num_samples: int = 8, seed: int = 0,
                 device: str | torch.device = "cpu", selection: str = "argmax", cor_alpha: float = 1.0,
                 threads: int | None = 1, depth_veto: float | DepthVeto | None = None, escape: Escape | None = None,
                 floor: Floor | None = None, turn_commit: TurnCommit | None = None):
        if len(members) != 2:
            raise ValueError("NoMaD-Neg needs two members: expert and negative")
        if selection not in SELECTIONS:
            raise ValueError(f"policy selection={selection!r}; choose argmax or argmin")
        self.selection, self.cor_alpha = selection, float(cor_alpha)
        super().__init__(members, control, num_samples, seed, device, threads=threads, depth_veto=depth_veto, escape=escape,
                         floor=floor, turn_commit=turn_commit)

    def reset(self) -> None:
        super().reset()
        self.cor_other_sample = self.cor_other_action = 0

    def episode_stats(self) -> dict[str, int]:
        """Also how often CoR picked another expert sample than sample 0 (``cor_other_sample``) and
        how often that changed the action (``cor_other_action``): what CoR does beyond NoMaD-PointGoal."""
        return {**super().episode_stats(), "cor_other_sample": self.cor_other_sample, "cor_other_action": self.cor_other_action}

    def choose(self, samples: list[np.ndarray], pointgoal: np.ndarray) -> np.ndarray:
        expert, negative = samples
        k = int(select_expert(expert, negative, self.cor_alpha, self.selection))
        if k != 0:
            self.cor_other_sample += 1
            if waypoints_to_action(expert[k], pointgoal, self.control) != waypoints_to_action(expert[0], pointgoal, self.control):
                self.cor_other_action += 1
        return expert[k]
