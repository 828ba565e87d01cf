"""Turn commitment (``policy.turn_commit``; a departure from the paper, off by default).

The timed-out goals of the best small-scale IL rows are spent turning in place, left and right turns almost
balanced (docs/results/2026-12-05_escape, NoMaD-Neg-veto: 92 % of their actions are turns, the rarer direction
49.5 % of them): a dither, the model's choice flipping sides between two neighbouring headings, each turn undoing
the one before. With ``turn_commit``, a turn against the previous step's turn repeats the previous turn instead:
once turning, the robot keeps turning the way it began until the model drives forward (or stops), so it sweeps
round to the headings it has not seen rather than returning to the two it has. The forward veto's turns
(:func:`.depth_veto.turn_instead`) are committed alike; the escape (:mod:`.escape`), which steers to a heading
of its own, comes after and is not overruled.
"""
from __future__ import annotations

from dataclasses import dataclass

from .escape import TURNS  # the two turn actions (and their sign)


@dataclass
class TurnCommit:
    """Its state in one episode: the turn taken at the previous step (None after anything else) and ``commits``,
    the turns it reversed."""

    last: int | None = None
    commits: int = 0

    def reset(self) -> None:
        self.last, self.commits = None, 0

    def act(self, action: int) -> int:
        """The action to take instead of ``action``: the previous step's turn where ``action`` is the other turn."""
        if action in TURNS and self.last is not None and action != self.last:
            self.commits += 1
            return self.last
        return action

    def taken(self, action: int) -> None:
        """Record the action the policy took this step (after the escape, which may have replaced it)."""
        self.last = int(action) if action in TURNS else None
