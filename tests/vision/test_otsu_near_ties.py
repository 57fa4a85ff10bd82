"""Multi-level Otsu thresholds on near ties, against exact rational arithmetic.

The dynamic programme of :func:`~terrain_odom.vision.sfta.multiotsu_thresholds`
runs in float32 and keeps that answer only when it is certified (every
choice beats its runner-up by more than the rounding bound). Mutation testing
found that taking float32's answer uncertified changed no test's outcome
(skimage, the other reference, is float32 too). Near-symmetric histograms
with large counts have candidates within float32's error of each other;
here the exact optimum is found with Python fractions.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest

from terrain_odom.vision.sfta import multiotsu_thresholds


def _exact(hist: np.ndarray, n_t: int) -> list[int]:
    """Return the lexicographically first thresholds maximising ``sum S_k**2 / P_k``, exactly."""
    levels = np.flatnonzero(hist)
    counts = [int(hist[v]) for v in levels]
    sums = [int(hist[v]) * int(v) for v in levels]
    best, arg = Fraction(-1), ()
    for cuts in itertools.combinations(range(1, levels.size), n_t):
        bounds = (0, *cuts, levels.size)
        value = sum(
            (
                Fraction(sum(sums[a:b]) ** 2, sum(counts[a:b]))
                for a, b in itertools.pairwise(bounds)
            ),
            Fraction(0),
        )
        if value > best:
            best, arg = value, cuts
    return [int(levels[c - 1]) for c in arg]


def _hist(counts: dict[int, int]) -> np.ndarray:
    hist = np.zeros(256, dtype=np.int64)
    hist[list(counts)] = list(counts.values())
    return hist


# histograms where float32's dynamic programme picks another threshold than exact arithmetic
NEAR_TIES = [
    (
        1,
        {
            4: 64118,
            64: 64121,
            74: 64118,
            124: 64118,
            131: 64118,
            181: 64118,
            191: 64118,
            251: 64118,
        },
        [131],
    ),
    (2, {21: 191484, 30: 191484, 35: 191482, 220: 191484, 225: 191484, 234: 191484}, [35, 225]),
]


@pytest.mark.parametrize(("n_t", "counts", "expected"), NEAR_TIES)
def test_near_ties_that_float32_gets_wrong_give_the_exact_optimum(n_t, counts, expected):
    hist = _hist(counts)
    assert _exact(hist, n_t) == expected
    assert multiotsu_thresholds(hist, n_t).tolist() == expected


def test_near_symmetric_histograms_match_exact_arithmetic():
    """Mirror-symmetric spikes of equal large counts, one count nudged: many near ties."""
    rng = np.random.default_rng(0)
    for _ in range(150):
        n_t = int(rng.integers(1, 3))
        levels = rng.choice(256, int(rng.integers(3, 7)), replace=False)
        levels = np.unique(np.r_[levels, 255 - levels])
        hist = np.zeros(256, dtype=np.int64)
        hist[levels] = int(rng.integers(1000, 200000))
        hist[levels[rng.integers(levels.size)]] += int(rng.integers(-3, 4))
        assert multiotsu_thresholds(hist, n_t).tolist() == _exact(hist, n_t), hist[levels]
