"""Constrained reward CoR (paper eq. CoR, from MixGAIL) and NoMaD-Neg's sample selection.

Our reading of the equation, for one expert sample ``a`` (a trajectory, flattened to a
vector of its ``len_traj_pred`` 2-D waypoints, in metres):

    d_k(a) = sqrt( (1/|a_k|) · Σ_{x ∈ a_k} ||a − x||₂² ),   k ∈ {E, N}

i.e. the root-mean-square Euclidean distance from ``a`` to the members of the set, taken
literally: the sum runs over the whole set a_E (which contains ``a`` itself, a zero term) and
is divided by |a_E|; ``exclude_self=True`` averages over the other k−1 expert samples instead.
With the Student-t kernel K(d) = (1 + d/α)^(−(α+1)/2) (d enters as written, not squared),

    CoR(a) = K(d_E) / (K(d_E) + K(d_N))  ∈ (0, 1).

K decreases with d, so CoR is high for samples close to the expert set and far from the
negative set. ``argmax`` (our default) therefore picks the expert sample farthest from the
predicted collisions; ``argmin`` is the paper's text (eq. a_e*), kept as an option.
"""
from __future__ import annotations

import numpy as np
import torch

SELECTIONS = ("argmax", "argmin")


def rms_distance(a: torch.Tensor, others: torch.Tensor, exclude_self: bool = False) -> torch.Tensor:
    """d for every row of ``a`` [k,...] to the set ``others`` [m,...] → [k]. With
    ``exclude_self`` (a is others), the zero self-distance is left out of the mean."""
    a2, o2 = a.reshape(a.shape[0], -1).double(), others.reshape(others.shape[0], -1).double()
    sq = torch.cdist(a2, o2).pow(2)  # [k, m]
    m = o2.shape[0]
    if exclude_self:
        if m < 2:
            raise ValueError("exclude_self needs at least two samples")
        return (sq.sum(1) / (m - 1)).sqrt()
    return (sq.sum(1) / m).sqrt()


def student_t(d: torch.Tensor, alpha: float) -> torch.Tensor:
    return (1.0 + d / alpha).pow(-(alpha + 1.0) / 2.0)


def cor(expert: torch.Tensor | np.ndarray, negative: torch.Tensor | np.ndarray, alpha: float = 1.0,
        exclude_self: bool = False) -> torch.Tensor:
    """CoR of every expert sample: expert [k,len,2], negative [m,len,2] → float64 [k]."""
    if not alpha > 0:
        raise ValueError(f"CoR alpha={alpha} must be positive")
    e, n = torch.as_tensor(expert), torch.as_tensor(negative)
    if e.shape[1:] != n.shape[1:] or e.shape[0] == 0 or n.shape[0] == 0:
        raise ValueError(f"CoR needs non-empty expert and negative samples of one shape, got {tuple(e.shape)} and {tuple(n.shape)}")
    k_e = student_t(rms_distance(e, e, exclude_self), alpha)
    k_n = student_t(rms_distance(e, n), alpha)
    return k_e / (k_e + k_n)


def select_expert(expert: torch.Tensor | np.ndarray, negative: torch.Tensor | np.ndarray, alpha: float = 1.0,
                  selection: str = "argmax", exclude_self: bool = False) -> int:
    """Index of the expert sample chosen by CoR under ``selection`` (argmax | argmin)."""
    if selection not in SELECTIONS:
        raise ValueError(f"selection={selection!r}; choose argmax or argmin")
    scores = cor(expert, negative, alpha, exclude_self)
    return int(torch.argmax(scores) if selection == "argmax" else torch.argmin(scores))
