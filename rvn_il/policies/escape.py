"""Escape from turning in place (``policy.escape_after``; a departure from the paper, off by default).

An IL policy that cannot see a way toward its goal often turns in place until the goal times out:
in the best small-scale rows half the episodes ended that way, their last goal's stretch ~98 % turns
(docs/results/2026-11-26_main/). With ``escape_after = N``, after N turns in place in a row (12: a full
circle at 30°) the policy stops deferring to the model for a moment: it turns to the heading it saw
most open (the model's depth head's nearest depth in the central columns past the bare floor,
:func:`.depth_veto.clearance` of :meth:`.depth_veto.Floor.standing`)
among those with at least ``escape_clearance`` metres free, the one nearest the goal's bearing (without
a depth head: the goal's bearing), then drives ``escape_steps`` forward steps there, unless the forward
veto (``policy.depth_veto``) calls a step blocked, and hands control back to the model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from rvn_data.conventions import Action

TURNS = {int(Action.TURN_LEFT): 1, int(Action.TURN_RIGHT): -1}


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@dataclass
class Escape:
    """The escape's settings (module docstring) and its state in one episode; ``theta_step`` in radians."""

    after: int
    theta_step: float
    steps: int = 4
    clearance: float = 1.0
    seen: list = field(default_factory=list)  # (heading since the turning began, free metres or None)
    heading: float = 0.0
    target: float | None = None
    left: int = 0  # forward steps of the escape still to drive
    escapes: int = 0

    def __post_init__(self):
        for name, low in (("after", 1), ("steps", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"policy.escape_{name}={value!r}: give a whole number >= {low}")
        if isinstance(self.clearance, bool) or not isinstance(self.clearance, (int, float)) or not self.clearance > 0:
            raise ValueError(f"policy.escape_clearance={self.clearance!r}: give metres > 0")

    def reset(self) -> None:
        self.seen, self.heading, self.target, self.left, self.escapes = [], 0.0, None, 0, 0

    def act(self, action: int, goal_bearing: float, free: float | None, blocked: bool) -> int:
        """The action to take instead of the model's ``action`` (after the veto): the model's unless an
        escape is under way or starts now. ``goal_bearing``: the goal's angle from the heading (rad);
        ``free``: metres free ahead (None without a depth head); ``blocked``: the veto's verdict on a step."""
        if self.target is None and self.left == 0:
            if action not in TURNS:  # the model drives (or stops): no stall
                self.seen, self.heading = [], 0.0
                return action
            self.seen.append((self.heading, free, wrap(self.heading + goal_bearing)))
            if len(self.seen) < self.after:
                self.heading = wrap(self.heading + TURNS[action] * self.theta_step)
                return action
            self.target, self.escapes = self._choose(), self.escapes + 1
        if self.target is not None:
            delta = wrap(self.target - self.heading)
            if abs(delta) > self.theta_step / 2:
                turn = int(Action.TURN_LEFT if delta > 0 else Action.TURN_RIGHT)
                self.heading = wrap(self.heading + TURNS[turn] * self.theta_step)
                return turn
            self.target, self.left = None, self.steps
        if blocked:  # the way out is not free after all: back to the model
            self.left, self.seen, self.heading = 0, [], 0.0
            return action
        self.left -= 1
        if self.left == 0:
            self.seen, self.heading = [], 0.0
        return int(Action.MOVE_FORWARD)

    def _choose(self) -> float:
        """The heading to escape along: nearest the goal among those free enough, else the freest."""
        goal = self.seen[-1][2]
        if self.seen[0][1] is None:
            return goal
        free = [(h, f) for h, f, _ in self.seen if f >= self.clearance]
        if free:
            return min(free, key=lambda hf: abs(wrap(hf[0] - goal)))[0]
        return max(self.seen, key=lambda s: s[1])[0]
