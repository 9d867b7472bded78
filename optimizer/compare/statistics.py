"""Statistics a reviewer accepts: per-method summaries over seeds and pairwise rank tests.

The tests are scipy's (two-sided Mann-Whitney U, no assumption of normality: walking distances of
a search's best are skewed and bounded below); Holm's step-down correction for the family of
pairwise tests; the effect size is the rank-biserial correlation r = 2 U / (n1 n2) - 1 (the
probability that the first method beats the second, minus the reverse), in -1 ... 1.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import mannwhitneyu


@dataclass(frozen=True)
class MethodSummary:
    """One method over its seeds: the final best distance's median, quartiles and best, and the
    fraction of seeds whose best walked at least the success distance without a fall in its
    stability check."""

    method: str
    seeds: int
    median: float
    q1: float
    q3: float
    best: float
    success: float


def summarise(method: str, distances: Sequence[float], successes: Sequence[bool]) -> MethodSummary:
    values = np.asarray(distances, dtype=float)
    q1, median, q3 = np.percentile(values, [25, 50, 75])
    return MethodSummary(
        method,
        len(values),
        float(median),
        float(q1),
        float(q3),
        float(values.max()),
        float(np.mean(successes)) if len(successes) else 0.0,
    )


@dataclass(frozen=True)
class PairTest:
    """Method ``a`` against method ``b``: U of ``a``, the raw and Holm-corrected p values, and the
    rank-biserial effect size (positive: ``a`` walks farther)."""

    a: str
    b: str
    u: float
    p: float
    p_holm: float
    effect: float

    def significant(self, alpha: float = 0.05) -> bool:
        return self.p_holm < alpha


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p values, in the order given (monotone, capped at 1)."""
    order = np.argsort(p_values, kind="stable")
    m = len(p_values)
    adjusted = [0.0] * m
    running = 0.0
    for rank, index in enumerate(order):
        running = max(running, min(1.0, (m - rank) * float(p_values[index])))
        adjusted[index] = running
    return adjusted


def pairwise(distances: Mapping[str, Sequence[float]]) -> list[PairTest]:
    """Every pair of methods (in the mapping's order), tested and corrected together."""
    pairs = list(itertools.combinations(distances, 2))
    raw = []
    for a, b in pairs:
        x, y = np.asarray(distances[a], dtype=float), np.asarray(distances[b], dtype=float)
        test = mannwhitneyu(x, y, alternative="two-sided")
        raw.append((float(test.statistic), float(test.pvalue), 2.0 * float(test.statistic) / (len(x) * len(y)) - 1.0))
    adjusted = holm([p for _, p, _ in raw])
    return [PairTest(a, b, u, p, p_holm, effect) for (a, b), (u, p, effect), p_holm in zip(pairs, raw, adjusted)]
