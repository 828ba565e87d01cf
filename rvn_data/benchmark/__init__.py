"""Closed-loop benchmark: run a policy over a split's episode set (`rvn-eval`), metrics tables.

``run_episode`` and ``InvalidActionError`` (rvn_data.benchmark.runner) load on first use, so that importing one of
this package's light modules (the baseline policies, the measures) does not load the navmesh, numba and scipy:
rvn-train's validation imports the goal follower, and started 0.6 s slower for it."""
from __future__ import annotations

__all__ = ["InvalidActionError", "run_episode"]


def __getattr__(name: str):
    if name in __all__:
        from rvn_data.benchmark import runner

        return getattr(runner, name)
    raise AttributeError(f"module 'rvn_data.benchmark' has no attribute {name!r}")
