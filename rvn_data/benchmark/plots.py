"""The report's plots: one bar per run of a metric with the paper's value of the same method
and split as a black tick, and the histogram of goals reached per episode. ``runs`` are
`rvn_data.benchmark.report.Run`s (``label``, ``metrics``, ``records``, ``paper()``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rvn_data.atomic import atomic_path
from rvn_data.benchmark.table import format_metric


def _save(fig, path: Path) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)


def bar_plot(runs: list, key: str, index: int, title: str, ylabel: str, digits: int, path: Path,
             top: float | None = None, symlog: bool = False) -> None:
    """Bars of ``key`` per run (``index``: the metric's place in the paper's rows), saved to ``path``."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    fig = Figure(figsize=(max(5.0, 1.3 * len(runs) + 2), 4), layout="constrained")
    ax = fig.add_subplot()
    x = np.arange(len(runs))
    ours = [r.metrics.get(key) for r in runs]
    ax.bar(x, [0.0 if v is None else v for v in ours], color=[f"C{i % 10}" for i in range(len(runs))])
    for i, v in enumerate(ours):
        ax.annotate(format_metric(v, digits), (i, 0 if v is None else v), ha="center", va="bottom", fontsize=8)
    ref = [(i, r.paper()[index]) for i, r in enumerate(runs) if r.paper() is not None]
    if ref:
        ax.scatter([i for i, _ in ref], [v for _, v in ref], marker="_", s=900, linewidths=3, color="black",
                   zorder=3)
        # a short line of its own as the legend's key: the 30-point tick itself would cover the text
        key = Line2D([], [], color="black", lw=3, label="paper (same method and split)")
        ax.legend(handles=[key], fontsize=8, loc="best", handlelength=1.5)
    if top is not None:
        ax.set_ylim(0, top)
    if symlog:  # CPK spans 0 (oracle) to thousands (random)
        ax.set_yscale("symlog", linthresh=10)
    ax.set_xticks(x, [r.label for r in runs], rotation=20, ha="right", fontsize=8)
    ax.set(title=title, ylabel=ylabel)
    _save(fig, path)


def goals_plot(runs: list, path: Path) -> None:
    """Histogram of goals reached per episode, one panel per run, saved to ``path``."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    cols = min(3, len(runs))
    rows = int(np.ceil(len(runs) / cols))
    fig = Figure(figsize=(4 * cols, 3 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for i, (ax, r) in enumerate(zip(axes, runs)):
        goals = np.array([e["goals_reached"] for e in r.records])
        top = int(max(goals.max(initial=0), 1))
        ax.hist(goals, bins=np.arange(top + 2) - 0.5, color=f"C{i % 10}")
        ax.set(title=f"{r.label}: E(G) {format_metric(r.metrics['E_G'], 2)}", xlabel="goals reached", ylabel="episodes")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    for ax in axes[len(runs):]:
        ax.axis("off")
    fig.suptitle("Goals reached per episode")
    _save(fig, path)


def ends_plot(runs: list, path: Path) -> None:
    """How each run's goals ended (share of goals attempted: success, collision, timeout), one stacked
    bar per run, with CPK over all km and outside timed-out stretches written above it; saved to ``path``."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(max(5.0, 1.3 * len(runs) + 2), 4.2), layout="constrained")
    ax = fig.add_subplot()
    x = np.arange(len(runs))
    bottom = np.zeros(len(runs))
    for kind, color in (("success", "tab:green"), ("collision", "tab:red"), ("timeout", "tab:orange"), ("stop_far", "tab:gray")):
        share = np.array([r.metrics["goal_ends"][kind] / max(1, sum(r.metrics["goal_ends"].values())) for r in runs])
        if kind == "stop_far" and not share.any():
            continue
        ax.bar(x, share, bottom=bottom, color=color, label=kind)
        bottom += share
    for i, r in enumerate(runs):
        ax.annotate(f"CPK {format_metric(r.metrics['CPK'], 0)}\nexcl. t/o {format_metric(r.metrics['CPK_excl_timeout'], 0)}",
                    (i, 1.0), ha="center", va="bottom", fontsize=7)
    ax.set_ylim(0, 1.25)
    ax.set_xticks(x, [r.label for r in runs], rotation=20, ha="right", fontsize=8)
    ax.set(title="How goals ended (share of goals attempted)", ylabel="share of goals")
    ax.legend(fontsize=8, loc="upper right", ncols=4)
    _save(fig, path)
