"""Tests for infoseek.envs.resampling: unbiasedness, low variance, ESS and input validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from infoseek.envs.resampling import (
    effective_sample_size,
    multinomial_resample,
    normalize_weights,
    stratified_resample,
    systematic_resample,
)

SAMPLERS = [systematic_resample, stratified_resample, multinomial_resample]

weight_lists = st.lists(
    st.floats(min_value=0.0, max_value=1.0, allow_nan=False, allow_infinity=False),
    min_size=1,
    max_size=40,
).filter(lambda ws: sum(ws) > 1e-6)


@settings(max_examples=200, deadline=None)
@given(weights=weight_lists, n=st.integers(1, 300), seed=st.integers(0, 2**32 - 1))
def test_systematic_counts_are_floor_or_ceil(weights: list[float], n: int, seed: int) -> None:
    w = np.asarray(weights) / np.sum(weights)
    idx = systematic_resample(np.asarray(weights), np.random.default_rng(seed), n)
    assert idx.dtype == np.int64 and idx.shape == (n,)
    assert np.all(np.diff(idx) >= 0)
    counts = np.bincount(idx, minlength=w.size)
    expected = n * w
    tol = 1e-9 * n
    assert np.all(counts >= np.floor(expected - tol))
    assert np.all(counts <= np.ceil(expected + tol))
    assert np.all(counts[w == 0] == 0)


@settings(max_examples=15, deadline=None)
@given(weights=weight_lists, seed=st.integers(0, 2**32 - 1))
@pytest.mark.parametrize("sampler", SAMPLERS)
def test_expected_counts_equal_n_w(sampler, weights: list[float], seed: int) -> None:
    """Each index's total count over many draws is consistent with the mean ``reps n w_i``:
    its two-sided tail probability under the binomial ``B(reps n, w_i)`` exceeds 1e-7 (the
    three samplers' counts are sums of independent indicators with those means, whose tails
    the binomial bounds; exact tails, so a weight of 1e-7 drawn once is no failure)."""
    from scipy import stats

    w = np.asarray(weights) / np.sum(weights)
    n, reps = 25, 1500
    rng = np.random.default_rng(seed)
    counts = np.stack([np.bincount(sampler(w, rng, n), minlength=w.size) for _ in range(reps)])
    total = counts.sum(axis=0)
    below = stats.binom.cdf(total, n * reps, w)
    above = stats.binom.sf(total - 1, n * reps, w)
    assert np.all(np.minimum(below, above) > 1e-7)


def test_systematic_has_lower_variance_than_multinomial() -> None:
    w = np.random.default_rng(1).dirichlet(np.ones(20))
    rng = np.random.default_rng(2)
    var = {}
    for sampler in (systematic_resample, multinomial_resample):
        counts = np.stack([np.bincount(sampler(w, rng), minlength=20) for _ in range(2000)])
        var[sampler.__name__] = counts.var(axis=0).sum()
    assert var["systematic_resample"] <= 0.25 * 20 + 1e-9
    assert var["systematic_resample"] < 0.5 * var["multinomial_resample"]


def test_multinomial_goodness_of_fit() -> None:
    from scipy import stats

    w = np.array([0.5, 0.25, 0.125, 0.0625, 0.0625])
    idx = multinomial_resample(w, np.random.default_rng(3), 20000)
    counts = np.bincount(idx, minlength=5)
    assert stats.chisquare(counts, 20000 * w).pvalue > 1e-4


def test_default_n_and_determinism() -> None:
    w = np.random.default_rng(4).random(50)
    for sampler in SAMPLERS:
        a = sampler(w, np.random.default_rng(7))
        b = sampler(w, np.random.default_rng(7))
        assert a.shape == (50,)
        np.testing.assert_array_equal(a, b)


def test_effective_sample_size() -> None:
    assert effective_sample_size(np.ones(10)) == pytest.approx(10.0)
    assert effective_sample_size(np.eye(10)[3]) == pytest.approx(1.0)
    # two equal masses: ESS = 2 regardless of how many zero weights
    assert effective_sample_size(np.array([0.0, 3.0, 0.0, 3.0])) == pytest.approx(2.0)
    w = np.array([0.5, 0.3, 0.2])
    assert effective_sample_size(w) == pytest.approx(1.0 / (0.25 + 0.09 + 0.04))


@pytest.mark.parametrize(
    ("weights", "match"),
    [
        (np.array([0.5, -0.1]), "non-negative"),
        (np.array([0.5, np.nan]), "finite"),
        (np.array([0.0, 0.0]), "positive sum"),
        (np.ones((2, 2)), "shape"),
        (np.array([]), "shape"),
    ],
)
def test_bad_weights(weights: np.ndarray, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        normalize_weights(weights)
    for sampler in SAMPLERS:
        with pytest.raises(ValueError, match="weights"):
            sampler(weights, np.random.default_rng(0))


def test_bad_rng_and_n() -> None:
    with pytest.raises(TypeError, match="rng"):
        systematic_resample(np.ones(3), 0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="n must"):
        systematic_resample(np.ones(3), np.random.default_rng(0), -1)
    with pytest.raises(ValueError, match="n must"):
        stratified_resample(np.ones(3), np.random.default_rng(0), 2.5)  # type: ignore[arg-type]
