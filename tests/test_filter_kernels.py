"""The filter's compiled kernels against the NumPy expressions they replaced (bit for bit) and
against independent references (closed forms, brute-force image sums)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from scipy.special import logsumexp

from infoseek.envs.log_weights import (
    bayes_step,
    ess_rows,
    log_ess_rows,
    logsumexp_rows,
    normalised,
)
from infoseek.envs.order_statistics import order_statistic_pair, stable_argsort
from infoseek.envs.resampling import systematic_resample_rows
from infoseek.envs.roughening import coordinate_ranges, jitter
from infoseek.envs.sensors import BeaconSensor, BearingSensor
from infoseek.envs.sensors.beacon_kernel import summed_beacon_log_likelihood
from infoseek.envs.sensors.wrapped_normal import summed_log_likelihood
from infoseek.envs.targets import reflect_into_interval
from infoseek.envs.tempering import TemperedLogEss, metropolis_accept, tempering_exponent


def _log_weights(rng: np.random.Generator, k: int, n: int) -> np.ndarray:
    values = rng.normal(0.0, 30.0, size=(k, n))
    values[rng.random((k, n)) < 0.1] = -np.inf
    values[:, 0] = rng.normal(0.0, 30.0, size=k)  # every row possible
    return values


def _numpy_logsumexp_rows(values: np.ndarray) -> np.ndarray:
    peak = values.max(axis=1)
    finite = np.isfinite(peak)
    shift = np.where(finite, peak, 0.0)
    with np.errstate(invalid="ignore"):
        sums = np.exp(values - shift[:, None]).sum(axis=1)
    out = peak.copy()
    for k in np.flatnonzero(finite):
        out[k] = peak[k] + math.log(float(sums[k]))
    return out


@pytest.mark.parametrize("n", [1, 7, 8, 129, 2000])
def test_log_weight_kernels_match_their_numpy_forms_and_scipy(n: int) -> None:
    rng = np.random.default_rng(n)
    values = _log_weights(rng, 5, n)
    values[0] = -np.inf  # a row of -inf has normaliser -inf
    out = logsumexp_rows(values)
    assert np.array_equal(out, _numpy_logsumexp_rows(values))
    assert out[0] == -np.inf
    np.testing.assert_allclose(out[1:], logsumexp(values[1:], axis=1), rtol=1e-13)
    log_weights = values[1:] - out[1:, None]
    weights = normalised(log_weights)
    expected = np.exp(log_weights)
    expected /= expected.sum(axis=1, keepdims=True)
    assert np.array_equal(weights, expected)
    assert np.array_equal(ess_rows(weights), np.array([1.0 / np.dot(w, w) for w in weights]))


def test_bayes_step_accepts_as_the_progressive_correction_rule_says() -> None:
    rng = np.random.default_rng(1)
    k, n, tau = 40, 300, 0.1
    prior = np.log(rng.dirichlet(np.full(n, 0.5), size=k))
    prior[:10] = -math.log(n)  # resampled rows
    loglik = rng.normal(0.0, 1.0, size=(k, n)) * rng.uniform(0.1, 30.0, size=(k, 1))
    loglik[3] = -np.inf  # impossible observation: never accepted
    live = rng.random(k) < 0.9
    log_weights, weights, log_z, accepted = bayes_step(prior, loglik, live, tau)
    full = prior + loglik
    expected_z = logsumexp(full, axis=1)
    np.testing.assert_allclose(log_z[np.isfinite(expected_z)], expected_z[np.isfinite(expected_z)])
    log_ess = 2.0 * logsumexp(full, axis=1) - logsumexp(2.0 * full, axis=1)
    prior_log_ess = 2.0 * logsumexp(prior, axis=1) - logsumexp(2.0 * prior, axis=1)
    margin = log_ess - (math.log(tau) + prior_log_ess)
    with np.errstate(invalid="ignore"):
        rule = live & np.isfinite(expected_z) & (expected_z >= -700.0) & (margin >= 0.0)
    decided = np.abs(np.nan_to_num(margin, nan=1.0)) > 1e-9  # away from round-off ties
    assert np.array_equal(accepted[decided], rule[decided])
    assert accepted.any() and not accepted.all()
    rows = np.flatnonzero(accepted)
    assert weights.shape == log_weights.shape == (rows.size, n)
    np.testing.assert_allclose(weights, np.exp(full[rows] - expected_z[rows, None]), atol=1e-15)
    assert np.array_equal(weights, normalised(log_weights))
    _, _, _, untempered = bayes_step(prior, loglik, live, None)
    with np.errstate(invalid="ignore"):
        assert np.array_equal(untempered, live & np.isfinite(expected_z) & (expected_z >= -700.0))


def _numpy_bayes_step(
    prior: np.ndarray, loglik: np.ndarray, live: np.ndarray, tau: float | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Bayes step written with NumPy calls, one quantity after the other."""
    full = prior + loglik
    log_z = _numpy_logsumexp_rows(full)
    with np.errstate(invalid="ignore"):
        accepted = live & np.isfinite(log_z) & (log_z >= -700.0)
        if tau is not None and accepted.any():
            rows = np.flatnonzero(accepted)
            old = prior[rows]
            prior_log_ess = 2.0 * _numpy_logsumexp_rows(old) - _numpy_logsumexp_rows(2.0 * old)
            posterior = 2.0 * log_z[rows] - _numpy_logsumexp_rows(2.0 * full[rows])
            accepted[rows] = posterior >= math.log(tau) + prior_log_ess
    rows = np.flatnonzero(accepted)
    return full[rows] - log_z[rows, None], log_z, accepted


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("tau", [None, 0.5, 0.05])
def test_bayes_step_gives_the_numbers_of_its_numpy_form(seed: int, tau: float | None) -> None:
    rng = np.random.default_rng(seed)
    k, n = 12, [1, 8, 129, 2000, 300, 57][seed]
    prior = np.log(rng.dirichlet(np.full(n, 0.3), size=k))
    prior[: k // 2] = -math.log(n)  # resampled rows, equal log-weights
    prior[1] = -0.7  # equal, unnormalised
    loglik = rng.normal(0.0, 1.0, size=(k, n)) * rng.uniform(0.05, 4.0, size=(k, 1))
    loglik[4] *= 400.0  # a sharp likelihood
    loglik[rng.random((k, n)) < 0.05] = -np.inf
    loglik[2] = -np.inf  # an impossible observation
    loglik[3] -= 800.0  # degenerate evidence
    live = rng.random(k) < 0.85
    log_weights, weights, log_z, accepted = bayes_step(prior, loglik, live, tau)
    expected_updated, expected_z, expected_accepted = _numpy_bayes_step(prior, loglik, live, tau)
    assert np.array_equal(accepted, expected_accepted)
    assert np.array_equal(log_z, expected_z)
    assert np.array_equal(log_weights, expected_updated)
    assert np.array_equal(weights, normalised(expected_updated))
    uniform = np.full((3, n), -0.25)
    expected_ess = 2.0 * _numpy_logsumexp_rows(uniform) - _numpy_logsumexp_rows(2.0 * uniform)
    assert np.array_equal(log_ess_rows(uniform), expected_ess)


def test_kernels_name_the_argument_they_reject() -> None:
    with pytest.raises(TypeError, match="values must be a float64 array"):
        logsumexp_rows(np.zeros((2, 3), dtype=np.float32))
    with pytest.raises(ValueError, match=r"log_weights must have shape \(K, N\)"):
        normalised(np.zeros(3))
    with pytest.raises(ValueError, match="log_likelihood must have the shape"):
        bayes_step(np.zeros((2, 3)), np.zeros((2, 4)), np.ones(2, bool), None)
    with pytest.raises(ValueError, match="live must have shape"):
        bayes_step(np.zeros((2, 3)), np.zeros((2, 3)), np.ones(3, bool), None)
    with pytest.raises(ValueError, match="weights must be"):
        systematic_resample_rows(np.ones((2, 3)), np.zeros(3))


def test_systematic_resampling_of_rows_is_searchsorted_of_the_cumulative_weights() -> None:
    rng = np.random.default_rng(2)
    for _ in range(50):
        k, n = int(rng.integers(1, 5)), int(rng.integers(1, 700))
        weights = rng.gamma(0.3, size=(k, n)) * np.exp(rng.uniform(-30.0, 0.0, (k, n)))
        weights[:, rng.integers(0, n, size=n // 2)] = 0.0
        weights[:, 0] += 1e-300
        uniforms = rng.random(k)
        cdf = np.cumsum(weights / weights.sum(axis=1, keepdims=True), axis=1)
        cdf[:, -1] = 1.0
        points = (uniforms[:, None] + np.arange(n)) / n
        rows = zip(cdf, points, strict=True)
        expected = np.stack([np.searchsorted(c, p, side="right") for c, p in rows])
        assert np.array_equal(
            systematic_resample_rows(weights, uniforms), np.minimum(expected, n - 1)
        )


_BIT_GENERATORS = {
    "pcg64": lambda r: np.random.PCG64(r),  # one compiled call for all sets
    "philox": lambda r: np.random.Philox(r),  # numba's Generator support, set by set
    "mixed": lambda r: np.random.PCG64(r) if r % 2 else np.random.MT19937(r),
}


@pytest.mark.parametrize("bit_generator", sorted(_BIT_GENERATORS))
def test_jitter_reflects_and_wraps_as_the_target_space_does(bit_generator: str) -> None:
    rng = np.random.default_rng(3)
    low, high = np.array([0.0, -1.0, 0.0]), np.array([40.0, 3.0, math.pi])
    periodic = np.array([False, False, True])
    particles = rng.uniform(low, high, size=(4, 500, 3))
    std = rng.uniform(0.0, 30.0, size=(4, 3))
    make = _BIT_GENERATORS[bit_generator]
    rngs = [np.random.Generator(make(r)) for r in range(4)]
    out = jitter(particles, std, rngs, low, high, periodic)
    references = [np.random.Generator(make(r)) for r in range(4)]
    noise = np.stack([reference.standard_normal((500, 3)) for reference in references])
    for used, reference in zip(rngs, references, strict=True):  # the streams moved alike
        assert np.array_equal(used.random(3), reference.random(3))
    moved = noise * std[:, None, :] + particles
    expected = moved.copy()
    for j in (0, 1):
        column = expected[..., j]
        outside = (column < low[j]) | (column > high[j])
        column[outside] = reflect_into_interval(column[outside], low[j], high[j])
    wrapped = np.mod(moved[..., 2] - low[2], high[2] - low[2])
    expected[..., 2] = low[2] + np.where(wrapped >= high[2] - low[2], 0.0, wrapped)
    assert np.array_equal(out, expected)
    assert np.all((out >= low) & (out <= high))
    ranges = particles.max(axis=1) - particles.min(axis=1)
    assert np.array_equal(coordinate_ranges(particles), ranges)


def _brute_force_log_density(residual: np.ndarray, sigma: float) -> np.ndarray:
    """log of the wrapped normal density by summing 41 images (independent of the sensor)."""
    images = residual[..., None] + 2.0 * math.pi * np.arange(-20, 21)
    log_terms = -0.5 * (images / sigma) ** 2 - math.log(sigma * math.sqrt(2.0 * math.pi))
    return logsumexp(log_terms, axis=-1)


@pytest.mark.parametrize("sigma", [0.02, 0.1, 0.5, 1.5])
def test_summed_bearing_likelihood_is_the_sum_of_received_wrapped_normals(sigma: float) -> None:
    rng = np.random.default_rng(4)
    groups, per, m, n = 3, 2, 4, 257
    sensor = BearingSensor(sigma=sigma)
    particles = rng.uniform(0.0, 40.0, size=(groups * per, n, 2))
    poses = rng.uniform(0.0, 40.0, size=(groups, m, 2))
    z = rng.uniform(-math.pi, math.pi, size=(groups, m, 1))
    z[0, 0, 0] = math.pi  # residuals at and beyond the seam
    received = rng.random((groups * per, m)) < 0.7
    total = sensor.summed_log_likelihood(z, poses, particles, received)
    assert total is not None
    expected = np.zeros((groups * per, n))
    for k in range(groups * per):
        g = k // per
        dx = particles[k, None, :, 0] - poses[g, :, 0, None]
        dy = particles[k, None, :, 1] - poses[g, :, 1, None]
        density = _brute_force_log_density(z[g] - np.arctan2(dy, dx), sigma)
        expected[k] = np.where(received[k][:, None], density, 0.0).sum(axis=0)
    np.testing.assert_allclose(total, expected, rtol=1e-12, atol=1e-12)
    grouped = particles.reshape(groups, per * n, 2)
    angle = np.arctan2(
        grouped[:, None, :, 1] - poses[:, :, 1, None], grouped[:, None, :, 0] - poses[:, :, 0, None]
    )
    again = summed_log_likelihood(angle, z[..., 0], received, sensor._image_sum)
    assert np.array_equal(again, total)
    single = sensor.log_likelihood(z[1], poses[1], particles[per])
    assert np.array_equal(np.where(received[per][:, None], single, 0.0).sum(axis=0), total[per])


def test_radix_argsort_is_numpys_stable_argsort_and_selection_is_sorting() -> None:
    rng = np.random.default_rng(5)
    for n in (0, 1, 2, 33, 500, 2000):
        values = rng.normal(0.0, 1.0, n) * np.exp(rng.uniform(-300.0, 300.0, n))
        values[: n // 4] = np.round(values[: n // 4], 0)  # ties, zeros of both signs
        values[: n // 8] *= -0.0
        assert np.array_equal(stable_argsort(values), np.argsort(values, kind="stable"))
        if n:
            ordered = np.sort(values)
            for low, high in ((0, n - 1), (min(1, n - 1), max(n - 3, 1)), (n // 3, n // 2)):
                low, high = min(low, high, n - 1), min(max(low, high), n - 1)
                assert order_statistic_pair(values, low, high) == (ordered[low], ordered[high])


def _beacon_case(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """Readings of 2 groups x 3 receivers, 4 beliefs of 40 particles (some at a receiver)."""
    groups, per, m, n = 2, 2, 3, 40
    poses = rng.uniform(0.0, 40.0, size=(groups, m, 2))
    z = rng.uniform(0.0, math.pi, size=(groups, m, 1))
    particles = np.stack(
        [rng.uniform(0.0, 40.0, n), rng.uniform(0.0, 40.0, n), rng.uniform(0.0, 2 * math.pi, n)],
        axis=-1,
    )[None].repeat(groups * per, axis=0)
    particles[:, :10, :2] = poses[0, 0] + rng.normal(0.0, 0.5, size=(groups * per, 10, 2))
    received = rng.random((groups * per, m)) < 0.7
    return z, poses, particles, received


def _quadrature_log_density(z: float, mu: np.ndarray) -> float:
    """``log p(z)`` of the direction of ``X ~ N(mu, I)`` folded modulo pi, by the trapezoid rule
    over the radius along the ray and along its reflection (independent of the sensor's
    formula): with ``a``, ``b`` the components of ``mu`` along and across the ray,
    ``|t u - mu|^2 = (t - a)^2 + b^2``, so each ray integrates ``t exp(-(t -+ a)^2 / 2)``
    over a window around its peak."""
    u = np.array([math.cos(z), math.sin(z)])
    along, across = float(u @ mu), float(u[0] * mu[1] - u[1] * mu[0])
    radial = 0.0
    for a in (along, -along):
        t = np.linspace(max(0.0, a - 12.0), max(a, 0.0) + 12.0, 20001)
        radial += float(np.trapezoid(t * np.exp(-0.5 * (t - a) ** 2), t))
    return -0.5 * across**2 + math.log(radial / (2.0 * math.pi))


@pytest.mark.parametrize("max_snr", [5.0, math.inf])
def test_summed_beacon_likelihood_is_the_sum_of_received_projected_normal_densities(
    max_snr: float,
) -> None:
    rng = np.random.default_rng(8)
    z, poses, particles, received = _beacon_case(rng)
    sensor = BeaconSensor(moment=1000.0, noise_std=1.0, max_snr=max_snr)
    total = sensor.summed_log_likelihood(z, poses, particles, received)
    assert total is not None and total.shape == received.shape[:1] + particles.shape[1:2]
    per = particles.shape[0] // z.shape[0]
    for k, n in [(0, 0), (1, 5), (2, 12), (3, 39), (2, 30)]:
        expected = 0.0
        for m in np.flatnonzero(received[k]):
            offset = particles[k, n, :2] - poses[k // per, m]  # receiver -> antenna, reversed
            r = math.hypot(*offset)
            e_r = -offset / r  # from the antenna to the receiver
            axis = np.array([math.cos(particles[k, n, 2]), math.sin(particles[k, n, 2])])
            mu = 1000.0 / r**3 * (3.0 * (axis @ e_r) * e_r - axis)  # the 2-D dipole near field
            mu = mu * min(1.0, max_snr / math.hypot(*mu))
            expected += _quadrature_log_density(float(z[k // per, m, 0]), mu)
        np.testing.assert_allclose(total[k, n], expected, rtol=1e-6, atol=1e-6)


def test_summed_beacon_likelihood_is_the_numpy_masked_sum_bit_for_bit_when_pinned(
    fresh_python: Callable[..., Any],
) -> None:
    """In the pinned numerical environment (a fresh process) the compiled pass returns the bits
    of ``log_likelihood`` masked and summed as NumPy sums it (so stored trials verify)."""
    script = """
import math, numpy as np
from infoseek.envs.sensors import BeaconSensor
rng = np.random.default_rng(9)
for max_snr in (5.0, math.inf):
    sensor = BeaconSensor(max_snr=max_snr)
    for groups, per, m, n in ((1, 1, 120, 500), (2, 3, 4, 300), (3, 1, 1, 2)):
        poses = rng.uniform(-5.0, 45.0, (groups, m, 2))
        z = rng.uniform(0.0, math.pi, (groups, m, 1))
        particles = rng.uniform(0.0, 40.0, (groups * per, n, 3))
        particles[:, : n // 2, :2] = poses[0, 0] + rng.normal(0.0, 0.05, (groups * per, n // 2, 2))
        particles[0, 0, :2] = poses[0, 0]  # a hypothesis at a receiver
        # hypotheses whose field at that receiver is on the cap's edge: |mu| = 2 moment / r^3
        # for an antenna pointing at it, so r = (2 moment / max_snr)^(1/3) (a few ulps and 1e-9 off)
        edge = (2.0 * 1000.0 / max_snr) ** (1.0 / 3.0) if max_snr < math.inf else 7.0
        factors = (1.0, 1 + 2e-16, 1 - 2e-16, 1 + 1e-12, 1 + 1e-9, 1 - 1e-9)
        for j, factor in enumerate(factors[: n - 1]):
            angle = rng.uniform(0.0, 2.0 * math.pi)
            direction = np.array([math.cos(angle), math.sin(angle)])
            particles[0, j + 1, :2] = poses[0, 0] - edge * factor * direction
            particles[0, j + 1, 2] = angle + j % 2 * math.pi
        received = rng.random((groups * per, m)) < 0.8
        each = np.stack([sensor.log_likelihood(z[k // per], poses[k // per], particles[k])
                         for k in range(groups * per)], axis=1)
        expected = np.where(received.T[:, :, None], each, 0.0).sum(axis=0)
        got = sensor.summed_log_likelihood(z, poses, particles, received)
        assert np.array_equal(got, expected), (max_snr, groups, per, m, n)
print("ok")
"""
    run = fresh_python(script, pinned=True)
    assert run.returncode == 0 and run.stdout.strip() == "ok", run.stderr[-2000:]


def test_summed_beacon_likelihood_refuses_bad_arrays() -> None:
    sensor = BeaconSensor(max_snr=5.0)
    z, poses, particles, received = _beacon_case(np.random.default_rng(10))
    with pytest.raises(ValueError, match="received must be"):
        sensor.summed_log_likelihood(z, poses, particles, received[:, :2])
    with pytest.raises(ValueError, match="multiple of G"):
        sensor.summed_log_likelihood(z, poses, particles[:3], received[:3])
    with pytest.raises(ValueError, match="z must have shape"):
        sensor.summed_log_likelihood(z[0], poses[0], particles, received)
    with pytest.raises(TypeError, match="received must be a bool array"):
        summed_beacon_log_likelihood(z[..., 0], poses, particles, received.astype(int), (1, 1, 5))
    assert sensor.summed_log_likelihood(z[:1], poses[:1], particles[:1, :1], received[:1]) is None


def _numpy_log_ess(values: np.ndarray) -> float:
    """log ESS of one row as NumPy calls compute it: ``2 log Z(v) - log Z(2 v)``."""

    def log_z(row: np.ndarray) -> float:
        peak = float(row.max())
        if not math.isfinite(peak):
            return peak
        return peak + math.log(float(np.exp(row - peak).sum()))

    with np.errstate(invalid="ignore"):
        return 2.0 * log_z(values) - log_z(2.0 * values)


def _numpy_tempering_exponent(
    log_weights: np.ndarray, loglik: np.ndarray, remaining: float, log_floor: float, steps: int
) -> float:
    hi = math.log(remaining)
    lo = hi - 60.0
    if _numpy_log_ess(log_weights + math.exp(lo) * loglik) < log_floor:
        return math.exp(lo)
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if _numpy_log_ess(log_weights + math.exp(mid) * loglik) >= log_floor:
            lo = mid
        else:
            hi = mid
    return math.exp(lo)


def _same_float(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


@pytest.mark.parametrize("n", [1, 9, 200, 2000])
def test_tempering_exponent_is_the_numpy_bisection_bit_for_bit(n: int) -> None:
    rng = np.random.default_rng(100 + n)
    found = 0
    for case in range(40):
        uniform = case % 2 == 0
        log_weights = np.full(n, -math.log(n)) if uniform else _log_weights(rng, 1, n)[0]
        loglik = rng.normal(0.0, 10.0 ** rng.uniform(-1, 3), size=n)
        loglik[rng.random(n) < 0.2] = -np.inf
        if case % 10 == 3:
            loglik[:] = -np.inf  # no particle is possible: the smallest exponent comes back
        remaining = float(rng.uniform(0.05, 1.0))
        log_floor = math.log(0.1) + _numpy_log_ess(log_weights)
        log_ess_at = TemperedLogEss(log_weights, loglik)
        exponents = np.sort(rng.uniform(0.0, 1.0, size=5))
        values = [log_ess_at(exponent) for exponent in exponents]
        for exponent, value in zip(exponents, values, strict=True):
            tempered = log_weights + exponent * loglik
            assert _same_float(value, _numpy_log_ess(tempered))
        if uniform and np.isfinite(values).all():  # equal weights: the ESS falls (docstring)
            assert np.all(np.diff(values) <= 1e-9)
        lam = tempering_exponent(log_weights, loglik, remaining, log_floor, 40)
        assert lam == _numpy_tempering_exponent(log_weights, loglik, remaining, log_floor, 40)
        assert 0.0 < lam <= remaining
        smallest = math.exp(math.log(remaining) - 60.0)
        if lam > smallest and n > 1:  # the floor holds at lam, by scipy's logsumexp
            tempered = log_weights + lam * loglik
            log_ess = 2.0 * logsumexp(tempered) - logsumexp(2.0 * tempered)
            assert log_ess >= log_floor - 1e-9
            found += 1
    assert found > 0 or n == 1


def test_tempering_exponent_refuses_rows_of_two_lengths() -> None:
    with pytest.raises(ValueError, match="log_weights and log_likelihood"):
        tempering_exponent(np.zeros(4), np.zeros(5), 1.0, -1.0, 40)


def test_metropolis_acceptance_is_the_masked_numpy_update() -> None:
    rng = np.random.default_rng(5)
    n, d = 500, 3
    particles, proposal = rng.normal(size=(n, d)), rng.normal(size=(n, d))
    loglik, proposal_loglik = rng.normal(size=n), rng.normal(size=n)
    past, proposal_past = rng.normal(size=n), rng.normal(size=n)
    loglik[:50] = proposal_loglik[:50] = -np.inf  # both impossible: rejected
    proposal_past[50:80] = -np.inf
    log_u = np.log(rng.random(n))
    with np.errstate(invalid="ignore"):
        accept = log_u < 0.7 * (proposal_loglik - loglik) + (proposal_past - past)
    expected = [np.where(accept[:, None], proposal, particles)]
    expected += [np.where(accept, proposal_loglik, loglik), np.where(accept, proposal_past, past)]
    metropolis_accept(particles, loglik, past, proposal, proposal_loglik, proposal_past, log_u, 0.7)
    for got, want in zip([particles, loglik, past], expected, strict=True):
        assert np.array_equal(got, want)
    assert 0 < accept.sum() < n and not accept[:80].any()
