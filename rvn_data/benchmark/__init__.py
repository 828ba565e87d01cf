"""Closed-loop benchmark: run a policy over a split's episode set (`rvn-eval`), metrics tables."""
from rvn_data.benchmark.runner import InvalidActionError, run_episode

__all__ = ["InvalidActionError", "run_episode"]
