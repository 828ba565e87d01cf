"""Significance tests between benchmark rows, for the results report.

- SR_1: Fisher's exact test on the 2×2 table (first-goal successes, failures) of the two rows,
  two-sided: are the two success rates different?
- CPK: collisions are counted per kilometre travelled, so the two rows are compared as Poisson
  rates with exposure (the distance driven): conditional on the total number of collisions
  c_a + c_b, c_a is binomial with p = km_a / (km_a + km_b) when the rates are equal (the exact
  conditional test of two Poisson rates), two-sided.

A row counts as a claim with 200 or more episodes; with fewer, differences of a few episodes are
noise, which the p-values say.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Iterable, Sequence

from scipy.stats import binomtest, fisher_exact


@dataclass(frozen=True)
class Row:
    """What the tests need of one evaluated row."""

    label: str
    successes: int  # episodes whose first goal was reached
    episodes: int
    collisions: int
    km: float  # distance travelled, kilometres

    @property
    def sr1(self) -> float:
        return self.successes / self.episodes if self.episodes else float("nan")

    @property
    def cpk(self) -> float:
        return self.collisions / self.km if self.km > 0 else float("nan")


def sr1_p(a: Row, b: Row) -> float:
    """Two-sided Fisher exact p of SR_1(a) = SR_1(b)."""
    table = [[a.successes, a.episodes - a.successes], [b.successes, b.episodes - b.successes]]
    return float(fisher_exact(table, alternative="two-sided").pvalue)


def cpk_p(a: Row, b: Row) -> float:
    """Two-sided exact conditional p of equal collision rates per km."""
    total = a.collisions + b.collisions
    if total == 0 or a.km <= 0 or b.km <= 0:
        return 1.0
    return float(binomtest(a.collisions, total, a.km / (a.km + b.km), alternative="two-sided").pvalue)


def format_p(p: float) -> str:
    return f"{p:.2g}" if p >= 1e-4 else "<1e-4"


def pairs(rows: Sequence[Row], compare: Iterable[tuple[str, str]] | None = None) -> list[tuple[Row, Row]]:
    """The pairs to test: ``compare`` (labels), else every pair in order."""
    if compare is None:
        return list(combinations(rows, 2))
    by_label = {r.label: r for r in rows}
    out = []
    for a, b in compare:
        missing = [x for x in (a, b) if x not in by_label]
        if missing:
            raise ValueError(f"--compare names {missing[0]!r}, which is not a row; rows: {', '.join(by_label)}")
        out.append((by_label[a], by_label[b]))
    return out


def significance_table(rows: Sequence[Row], compare: Iterable[tuple[str, str]] | None = None) -> str:
    """Markdown table of both tests for each pair."""
    lines = ["| A | B | SR_1 A | SR_1 B | Fisher p (SR_1) | CPK A | CPK B | p (CPK, Poisson rates) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for a, b in pairs(rows, compare):
        lines.append(f"| {a.label} | {b.label} | {a.sr1:.3f} ({a.successes}/{a.episodes}) | "
                     f"{b.sr1:.3f} ({b.successes}/{b.episodes}) | {format_p(sr1_p(a, b))} | {a.cpk:.0f} | {b.cpk:.0f} | "
                     f"{format_p(cpk_p(a, b))} |")
    return "\n".join(lines) + "\n"
