"""Significance tests between benchmark rows, for the results report.

- SR_1: Fisher's exact test on the 2×2 table (first-goal successes, failures) of the two rows,
  two-sided: are the two success rates different?
- CPK: collisions are counted per kilometre travelled, so the two rows are compared as Poisson
  rates with exposure (the distance driven): conditional on the total number of collisions
  c_a + c_b, c_a is binomial with p = km_a / (km_a + km_b) when the rates are equal (the exact
  conditional test of two Poisson rates), two-sided.

Rows run on the same episodes (the same episode ids, as every row of one experiment) are also
compared pair by pair, which is the more sensitive test there:

- SR_1: McNemar's exact test on the episodes only one of the two rows succeeds on (won–lost;
  binomial with p = 1/2 on the discordant pairs), two-sided.
- CPK: the ratio CPK(A) / CPK(B) with a 95 % bootstrap interval over episodes, and a paired
  randomisation test: under equal rates the two rows' (collisions, km) of an episode are
  exchangeable, so the labels are swapped per episode at random (`PERMUTATIONS` draws, a fixed seed:
  the same records give the same p) and the observed |log ratio| is ranked among the draws'.

A row counts as a claim with 200 or more episodes; with fewer, differences of a few episodes are
noise, which the p-values say.

Rows of several training seeds: the recipes label a row of another seed than the run's own
``"<method> seed<s>"`` (jobs/small_experiment.sh's ``SEEDS``). A compared pair (A, B) whose rows of other
seeds are there too ("A seed1", "B seed1") is also tested pooled over the seeds (`pooled_pairs`,
`pool_rows`): every episode of each seed's pair is one paired observation, keyed by seed and episode.

Rows of several checkpoints of one training run: the recipes label a row of a checkpoint other than the run's latest
``"<method> ckpt<step>"`` (RL: env steps, IL: training steps; ``EVAL_CHECKPOINTS`` of jobs/rl_small.sh and
jobs/small_experiment.sh), since an RL row at small scale moves as much between neighbouring checkpoints as between
budgets. A row "A" with such rows on the same episodes is also read as
their mean (`over_checkpoints`, `mean_row`): per episode the share of its checkpoints that reached the first goal and
their mean collisions and km. Pairs of such rows are tested on the episodes, the unit that is sampled: SR_1 by a paired
randomisation test on the per-episode differences in that share (signs flipped per episode; with shares of 0 or 1 it is
McNemar's test, which is then used), CPK as before.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from itertools import combinations
from typing import Iterable, Sequence

import numpy as np
from scipy.stats import binomtest, fisher_exact

PERMUTATIONS = 10_000
SEED_LABEL = re.compile(r"^(?P<base>.+) seed(?P<seed>\d+)$")  # the recipes' label of another training seed's row
CKPT_LABEL = re.compile(r"^(?P<base>.+) ckpt(?P<steps>\d+)$")  # ... and of a run's checkpoint other than its latest
# another seed's row of either kind: "A seed1", or its checkpoint's "A seed1 ckpt40" (small_experiment.sh's labels)
SEEDED_LABEL = re.compile(r"^(?P<base>.+) seed(?P<seed>\d+)(?: ckpt\d+)?$")


def seed_row_label(label: str, tag: str) -> str:
    """The label of row ``label``'s run trained with another seed (``tag``: "seed1"): "A" -> "A seed1",
    "A ckpt40" -> "A seed1 ckpt40" (the seed before the checkpoint, as the recipes write it); no tag: ``label``."""
    if not tag:
        return label
    m = CKPT_LABEL.match(label)
    return f"{m['base']} {tag} ckpt{m['steps']}" if m else f"{label} {tag}"


@dataclass(frozen=True)
class Row:
    """What the tests need of one evaluated row."""

    label: str
    successes: float  # episodes whose first goal was reached (a mean over checkpoints: fractional)
    episodes: int
    collisions: float
    km: float  # distance travelled, kilometres
    # per episode id: (first goal reached, collisions, km), of a mean row (first goal: the share of checkpoints that
    # reached it); empty when the row's records are not at hand
    per_episode: dict = field(default_factory=dict, compare=False)

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


def paired(a: Row, b: Row, seed: int = 0) -> dict | None:
    """McNemar and the paired CPK tests of two rows on the same episodes; None when their episodes differ."""
    if not a.per_episode or set(a.per_episode) != set(b.per_episode):
        return None
    keys = sorted(a.per_episode)
    ea, eb = np.array([a.per_episode[k] for k in keys], float), np.array([b.per_episode[k] for k in keys], float)
    won, lost, mcnemar = _first_goal_test(ea[:, 0], eb[:, 0], seed)
    rng = np.random.default_rng(seed)

    def log_ratio(ca, ka, cb, kb):  # +0.5: defined with no collisions on one side
        return np.log((ca + 0.5) / np.maximum(ka, 1e-9)) - np.log((cb + 0.5) / np.maximum(kb, 1e-9))

    observed = log_ratio(ea[:, 1].sum(), ea[:, 2].sum(), eb[:, 1].sum(), eb[:, 2].sum())
    swap = rng.random((PERMUTATIONS, len(keys))) < 0.5
    sums = [np.where(swap, y, x).sum(1) for x, y in ((ea[:, 1], eb[:, 1]), (ea[:, 2], eb[:, 2]),
                                                    (eb[:, 1], ea[:, 1]), (eb[:, 2], ea[:, 2]))]
    drawn = log_ratio(*sums)
    p_cpk = float((1 + np.sum(np.abs(drawn) >= abs(observed) - 1e-12)) / (1 + PERMUTATIONS))
    ratio = a.cpk / b.cpk if b.cpk else float("nan")
    return {"won": won, "lost": lost, "mcnemar_p": mcnemar, "cpk_ratio": ratio, "cpk_paired_p": p_cpk,
            "cpk_ratio_ci": _ratio_interval(ea[:, 1:], eb[:, 1:], rng) if np.isfinite(ratio) else (np.nan, np.nan)}


def _first_goal_test(sa: np.ndarray, sb: np.ndarray, seed: int) -> tuple:
    """(won, lost, p) of two rows' first goals on the same episodes: McNemar's exact test where every episode's value
    is 0 or 1; else (a mean over checkpoints) won and lost are the summed per-episode differences either way and p a
    paired randomisation test of their sum (signs flipped per episode, `PERMUTATIONS` draws, its own seeded stream)."""
    if np.isin(sa, (0, 1)).all() and np.isin(sb, (0, 1)).all():
        won, lost = int(((sa > 0) & (sb == 0)).sum()), int(((sa == 0) & (sb > 0)).sum())
        return won, lost, float(binomtest(won, won + lost).pvalue) if won + lost else 1.0
    d = sa - sb
    won, lost = float(d[d > 0].sum()), float(-d[d < 0].sum())
    flip = np.random.default_rng([seed, 1]).random((PERMUTATIONS, len(d))) < 0.5
    drawn = np.where(flip, -d, d).sum(1)
    return won, lost, float((1 + np.sum(np.abs(drawn) >= abs(d.sum()) - 1e-12)) / (1 + PERMUTATIONS))


def _ratio_interval(ea: np.ndarray, eb: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    """95 % interval of CPK(A) / CPK(B), the ratio the table prints, from each row's (collisions, km) per episode:
    the percentiles of its bootstrap draws over episodes (the randomisation test's +0.5 only defines its statistic
    with no collisions on a side; in this interval it put a ratio of 0 at [0.05, 0.33] with none against 5). A draw
    with no collisions on either side has no ratio and is left out; one with none on B's side is unbounded (inf).
    With no collisions in A every draw is 0, which bounds nothing: the interval is then the exact conditional one of
    two Poisson rates (`cpk_p`'s binomial, Clopper-Pearson), B's collisions rounded down where B is a mean over
    checkpoints (a wider interval; unbounded below one collision)."""
    (ca, ka), (cb, kb) = ea.sum(0), eb.sum(0)
    if ca == 0:
        if int(cb) == 0:  # a mean row's fraction of one collision bounds nothing
            return 0.0, float("inf")
        high = binomtest(0, int(cb), ka / (ka + kb)).proportion_ci(0.95, method="exact").high
        return 0.0, float(high / (1 - high) * kb / ka)
    idx = rng.integers(0, len(ea), (PERMUTATIONS, len(ea)))
    (da, dka), (db, dkb) = ea[idx].sum(1).T, eb[idx].sum(1).T
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = np.nanpercentile((da / dka) / (db / dkb), [2.5, 97.5])
    return float(lo), float(hi)


def format_p(p: float) -> str:
    return f"{p:.2g}" if p >= 1e-4 else "<1e-4"


def paired_cells(t: dict) -> str:
    """A `paired` result as two table cells: won–lost with its p; the CPK ratio with its interval and paired p."""
    won, lost = (str(int(x)) if float(x).is_integer() else f"{x:.1f}" for x in (t["won"], t["lost"]))  # a mean's: .1
    lo, hi = t["cpk_ratio_ci"]
    return (f"{won}–{lost}, {format_p(t['mcnemar_p'])} | "
            f"{t['cpk_ratio']:.2f} [{lo:.2f}, {hi:.2f}], {format_p(t['cpk_paired_p'])}")


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
    lines = ["| A | B | SR_1 A | SR_1 B | Fisher p (SR_1) | CPK A | CPK B | p (CPK, Poisson rates) | "
             "same episodes: won–lost, McNemar p | CPK A / B [95 % CI], paired p |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for a, b in pairs(rows, compare):
        pair = paired(a, b)
        extra = "– | –" if pair is None else paired_cells(pair)
        lines.append(f"| {a.label} | {b.label} | {a.sr1:.3f} ({a.successes}/{a.episodes}) | "
                     f"{b.sr1:.3f} ({b.successes}/{b.episodes}) | {format_p(sr1_p(a, b))} | {a.cpk:.0f} | {b.cpk:.0f} | "
                     f"{format_p(cpk_p(a, b))} | {extra} |")
    return "\n".join(lines) + "\n"


def pooled_pairs(rows: Sequence[Row], compare: Iterable[tuple[str, str]] | None = None) -> list[tuple[Row, Row, str]]:
    """The pairs to test pooled over training seeds: for each pair of ``compare`` (default: every pair) whose labels
    name no seed, with the rows "A seed<s>" and "B seed<s>" of at least one other seed on the same episodes as each
    other, (pooled A, pooled B, which rows were pooled); for checkpoint rows "A ckpt<n>", their seed's "A seed<s>
    ckpt<n>" (`seed_row_label`). A pooled row's episodes are keyed by (seed label, episode)."""
    by_label = {r.label: r for r in rows}
    seeds = sorted({int(m["seed"]) for r in rows if (m := SEEDED_LABEL.match(r.label))})
    base = [r.label for r in rows if not SEEDED_LABEL.match(r.label)]
    out = []
    for a, b in (list(combinations(base, 2)) if compare is None else compare):
        if a not in by_label or b not in by_label or SEEDED_LABEL.match(a) or SEEDED_LABEL.match(b):
            continue
        tags = [""] + [f"seed{s}" for s in seeds
                       if seed_row_label(a, f"seed{s}") in by_label and seed_row_label(b, f"seed{s}") in by_label]
        of_a = {t: by_label[seed_row_label(a, t)] for t in tags}
        of_b = {t: by_label[seed_row_label(b, t)] for t in tags}
        if len(tags) < 2 or any(not of_a[t].per_episode or set(of_a[t].per_episode) != set(of_b[t].per_episode)
                                for t in tags):
            continue
        out.append((pool_rows(a, of_a), pool_rows(b, of_b), " + ".join(t or "unlabelled" for t in tags)))
    return out


def pool_rows(label: str, rows: dict) -> Row:
    """One row of several (``{tag: row}``, e.g. one per training seed): totals summed, each episode keyed (tag, its key)."""
    return Row(label, sum(r.successes for r in rows.values()), sum(r.episodes for r in rows.values()),
               sum(r.collisions for r in rows.values()), sum(r.km for r in rows.values()),
               {(tag, k): v for tag, r in rows.items() for k, v in r.per_episode.items()})


def pooled_table(rows: Sequence[Row], compare: Iterable[tuple[str, str]] | None = None) -> str:
    """Markdown table of the paired tests of `pooled_pairs` (empty when no pair has rows of other seeds)."""
    found = pooled_pairs(rows, compare)
    if not found:
        return ""
    lines = ["| A | B | seeds pooled | episodes | SR_1 A | SR_1 B | won–lost, McNemar p | CPK A | CPK B | "
             "CPK A / B [95 % CI], paired p |", "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for a, b, which in found:
        won_lost, ratio = paired_cells(paired(a, b)).split(" | ")
        lines.append(f"| {a.label} | {b.label} | {which} | {a.episodes} | {a.sr1:.3f} | {b.sr1:.3f} | {won_lost} | "
                     f"{a.cpk:.1f} | {b.cpk:.1f} | {ratio} |")
    return "\n".join(lines) + "\n"


def over_checkpoints(rows: Sequence[Row]) -> tuple[list[Row], dict[str, list[Row]]]:
    """``rows`` with each row "A" that has rows "A ckpt<n>" on its episodes read as the mean over them all
    (`mean_row`, labelled "A"), those rows left out; and {"A": the rows averaged, oldest checkpoint first, A last}.
    A checkpoint row whose episodes differ from A's, or with no row A, stays a row of its own."""
    by_label = {r.label: r for r in rows}
    found: dict[str, list[tuple[int, Row]]] = {}
    for r in rows:
        m = CKPT_LABEL.match(r.label)
        base = by_label.get(m["base"]) if m else None
        if base is not None and base.per_episode and set(r.per_episode) == set(base.per_episode):
            found.setdefault(base.label, []).append((int(m["steps"]), r))
    groups = {label: [r for _, r in sorted(found[label], key=lambda x: x[0])] + [by_label[label]] for label in found}
    averaged = {r.label for group in groups.values() for r in group[:-1]}
    means = [mean_row(r.label, groups[r.label]) if r.label in groups else r for r in rows if r.label not in averaged]
    return means, groups


def mean_row(label: str, rows: Sequence[Row]) -> Row:
    """One row as the mean of several on the same episodes (a run's checkpoints): per episode the share of the rows
    that reached the first goal and their mean collisions and km; SR_1 the mean of theirs, CPK their collisions over
    their km."""
    n, keys = len(rows), rows[-1].per_episode
    per = {k: tuple(float(np.mean([r.per_episode[k][i] for r in rows])) for i in range(3)) for k in keys}
    return Row(label, sum(r.successes for r in rows) / n, rows[-1].episodes, sum(r.collisions for r in rows) / n,
               sum(r.km for r in rows) / n, per)


def checkpoint_table(groups: dict[str, list[Row]]) -> str:
    """Markdown table: each row read over its checkpoints, their SR_1 and CPK one by one (oldest first) and over all."""
    lines = ["| row | checkpoints (steps; the row's own last) | SR_1 of each | SR_1 mean | CPK of each | CPK over all |",
             "|---|---|---|---:|---|---:|"]
    for label, group in groups.items():
        steps = [CKPT_LABEL.match(r.label)["steps"] for r in group[:-1]] + ["the row's"]
        mean = mean_row(label, group)
        lines.append(f"| {label} | {', '.join(steps)} | {', '.join(f'{r.sr1:.3f}' for r in group)} | {mean.sr1:.3f} | "
                     f"{', '.join(f'{r.cpk:.0f}' for r in group)} | {mean.cpk:.1f} |")
    return "\n".join(lines) + "\n"


def mean_pairs_table(means: Sequence[Row], groups: dict[str, list[Row]],
                     compare: Iterable[tuple[str, str]] | None = None) -> str:
    """Markdown table of the paired tests of each pair with a row read over its checkpoints (empty when none)."""
    lines = ["| A | B | checkpoints A / B | episodes | SR_1 A | SR_1 B | won–lost (first goals), p | CPK A | CPK B | "
             "CPK A / B [95 % CI], paired p |", "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for a, b in pairs(means, compare):
        t = paired(a, b) if a.label in groups or b.label in groups else None
        if t is None:
            continue
        won_lost, ratio = paired_cells(t).split(" | ")
        lines.append(f"| {a.label} | {b.label} | {len(groups.get(a.label, [a]))} / {len(groups.get(b.label, [b]))} | "
                     f"{a.episodes} | {a.sr1:.3f} | {b.sr1:.3f} | {won_lost} | {a.cpk:.1f} | {b.cpk:.1f} | {ratio} |")
    return "\n".join(lines) + "\n" if len(lines) > 2 else ""
