"""Tests of infoseek.planners.information: MI of particle beliefs (eq. 9, 13-19)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import logsumexp

from infoseek.envs.sensors import BearingSensor, RangeSensor
from infoseek.envs.sensors.beacon import BeaconSensor
from infoseek.planners.information import (
    MIEstimate,
    mutual_information,
    mutual_information_batch,
    noise_std,
    pairwise_mutual_information,
    select_method,
    uniform_bin_edges,
)


def _belief(rng: np.random.Generator, n: int, target_dim: int) -> tuple[np.ndarray, np.ndarray]:
    """A non-uniform particle set: two blobs in the 40 x 40 square, random weights."""
    centres = np.array([[14.0, 22.0], [27.0, 15.0]])
    blob = rng.integers(0, 2, n)
    xy = centres[blob] + rng.normal(0.0, [2.5, 4.0], (n, 2))
    xy = np.clip(xy, 0.5, 39.5)
    if target_dim == 3:
        xy = np.column_stack([xy, rng.uniform(0.0, 2.0 * np.pi, n)])
    weights = rng.gamma(0.7, size=n)
    return xy, weights / weights.sum()


def _brute_force(sensor, poses, particles, weights, rng, n_samples=6000, edges=None):
    """Independent MC estimate of I: mean of log p(z|theta) - log p(z), and its std error.

    With ``edges`` the observation is the bin index of z (probabilities from bin_probabilities).
    """
    index = rng.choice(particles.shape[0], size=n_samples, p=weights)
    terms = np.zeros(n_samples)
    log_mixture_terms = np.zeros((n_samples, particles.shape[0]))
    for pose in poses:
        z = sensor.sample(pose, particles[index], rng)  # (S, obs_dim)
        if edges is None:
            log_lik = sensor.log_likelihood(z, pose, particles)  # (S, N)
        else:
            bins = np.clip(np.searchsorted(edges, z[:, 0], side="right") - 1, 0, len(edges) - 2)
            probs = sensor.bin_probabilities(edges, pose, particles)  # (N, Q)
            log_lik = np.log(np.maximum(probs[:, bins].T, 1e-300))
        log_mixture_terms += log_lik
    terms = log_mixture_terms[np.arange(n_samples), index] - logsumexp(
        log_mixture_terms + np.log(weights), axis=1
    )
    return terms.mean(), terms.std(ddof=1) / math.sqrt(n_samples)


def _beacon_belief(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A non-uniform beacon belief 5-15 units from BEACON_POSES (moderate noise)."""
    particles = np.column_stack(
        [rng.normal([20.0, 20.0], [2.0, 3.0], (n, 2)), rng.uniform(0.0, 2.0 * np.pi, n)]
    )
    weights = rng.gamma(0.7, size=n)
    return particles, weights / weights.sum()


BEACON_POSES = np.array([[20.0, 29.0], [28.0, 20.0]])


POSE_SETS = {
    1: np.array([[3.0, 4.0]]),
    2: np.array([[3.0, 4.0], [36.0, 30.0]]),
}


@pytest.mark.parametrize("k", [1, 2])
@pytest.mark.parametrize(
    "sensor", [BearingSensor(0.1), RangeSensor(0.5, 60.0)], ids=["bearing", "range"]
)
def test_default_path_matches_brute_force(sensor, k):
    rng = np.random.default_rng(10 + k)
    particles, weights = _belief(rng, 400, 2)
    poses = POSE_SETS[k]
    value = mutual_information(sensor, poses, particles, weights)
    assert value.method == "fft"
    mean, stderr = _brute_force(sensor, poses, particles, weights, rng)
    assert abs(value - mean) < 3 * stderr + 0.01, (value, mean, stderr)


@pytest.mark.parametrize("k", [1, 2])
def test_beacon_quantised_matches_brute_force_of_bins(k):
    sensor = BeaconSensor()
    rng = np.random.default_rng(20 + k)
    particles, weights = _belief(rng, 400, 3)
    # Near (about 8 units) and far poses: sharp and broad likelihoods mixed.
    poses = np.array([[12.0, 14.0], [30.0, 30.0]])[:k]
    edges = uniform_bin_edges(sensor.domain, 48)
    value = mutual_information(sensor, poses, particles, weights, edges=edges)
    assert value.method == "quantised"
    mean, stderr = _brute_force(sensor, poses, particles, weights, rng, edges=edges)
    assert abs(value - mean) < 3 * stderr + 0.01, (value, mean, stderr)


@pytest.mark.parametrize("k", [1, 2])
def test_beacon_general_path_matches_continuous_brute_force(k):
    """Moderate noise (the beacon 5-15 units away): the quadrature resolves the likelihoods."""
    sensor = BeaconSensor()
    rng = np.random.default_rng(30 + k)
    particles, weights = _beacon_belief(rng, 300)
    poses = BEACON_POSES[:k]
    fine = 1024 if k == 1 else 256
    value = mutual_information(
        sensor, poses, particles, weights, method="quadrature", n_points=fine
    )
    assert value > 0.3  # informative enough for the comparison to mean something
    mean, stderr = _brute_force(sensor, poses, particles, weights, rng)
    assert abs(value - mean) < 3 * stderr + 0.01, (value, mean, stderr)


@pytest.mark.parametrize("k", [1, 2])
@pytest.mark.parametrize(
    "sensor", [BearingSensor(0.1), RangeSensor(0.5, 60.0)], ids=["bearing", "range"]
)
def test_fast_path_equals_general_path(sensor, k):
    rng = np.random.default_rng(40 + k)
    particles, weights = _belief(rng, 300, 2)
    for poses in (POSE_SETS[k], rng.uniform(0.0, 40.0, (k, 2))):
        fast = mutual_information(sensor, poses, particles, weights, method="fft")
        general = mutual_information(
            sensor, poses, particles, weights, method="quadrature", n_points=1024 if k == 1 else 320
        )
        assert fast.method == "fft" and general.method == "quadrature"
        assert abs(fast - general) < 1e-3, (fast, general)
        assert abs(fast.conditional_entropy - general.conditional_entropy) < 1e-3


def test_fast_path_on_a_concentrated_belief():
    """A posterior narrower than one grid cell still agrees (moment-preserving assignment)."""
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(5)
    particles = rng.normal([20.0, 20.0], 0.05, (200, 2))
    weights = rng.random(200)
    poses = np.array([[3.0, 4.0], [3.5, 4.2]])
    fast = mutual_information(sensor, poses, particles, weights, method="fft")
    general = mutual_information(
        sensor, poses, particles, weights, method="quadrature", n_points=384
    )
    assert abs(fast - general) < 1e-3


@pytest.mark.parametrize(
    ("sensor", "target_dim"),
    [(BearingSensor(0.1), 2), (RangeSensor(0.5, 60.0), 2), (BeaconSensor(), 3)],
    ids=["bearing", "range", "beacon"],
)
def test_bounds_and_redundancy(sensor, target_dim):
    rng = np.random.default_rng(50)
    particles, weights = _belief(rng, 300, target_dim)
    pose = np.array([[9.0, 9.0]])
    single = mutual_information(sensor, pose, particles, weights)
    twice = mutual_information(sensor, np.vstack([pose, pose]), particles, weights)
    for value, k in ((single, 1), (twice, 2)):
        assert value >= -1e-9
        assert value == pytest.approx(value.entropy - value.conditional_entropy, abs=1e-9)
        if value.method == "quantised":  # discrete entropies of the bin index: I <= H <= log Q^k
            assert value <= value.entropy + 1e-12
            assert value.entropy <= k * math.log(256 if k == 1 else 96) + 1e-9
        else:  # differential entropies: H(z) <= log |Z|^k, H(z | theta) = k H(noise)
            assert value.entropy <= k * math.log(sensor.domain.size) + 1e-9
            assert value.conditional_entropy == pytest.approx(
                k * (0.5 * math.log(2 * math.pi * math.e) + math.log(noise_std(sensor))), abs=1e-3
            )
    # The same observation twice is redundant but not useless.
    assert single < twice < 2 * single


def test_mi_is_zero_for_uninformative_sensor_and_positive_otherwise():
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(6)
    # All particles on a ray from the sensor: identical bearings, nothing to learn.
    t = rng.uniform(5.0, 30.0, 200)
    particles = np.column_stack([2.0 + t, 2.0 + t])
    weights = np.full(200, 1 / 200)
    for method in ("fft", "quadrature"):
        assert (
            abs(mutual_information(sensor, [[2.0, 2.0]], particles, weights, method=method)) < 1e-3
        )
        assert mutual_information(sensor, [[30.0, 2.0]], particles, weights, method=method) > 0.5


def test_quantised_is_monotone_under_nested_refinement_and_tends_to_continuous():
    sensor = BeaconSensor()
    rng = np.random.default_rng(7)
    particles, weights = _beacon_belief(rng, 300)
    for k in (1, 2):
        poses = BEACON_POSES[:k]
        continuous = mutual_information(
            sensor, poses, particles, weights, method="quadrature", n_points=1024 if k == 1 else 256
        )
        values = [
            mutual_information(sensor, poses, particles, weights, n_points=q)
            for q in (4, 8, 16, 32, 64, 128, 256)
        ]
        assert all(v.method == "quantised" for v in values)
        assert all(b >= a - 1e-12 for a, b in zip(values, values[1:], strict=False)), values
        assert values[-1] <= continuous + 1e-6  # data processing inequality
        assert continuous - values[-1] < 0.005
        assert values[0] < continuous - 0.1  # coarse bins lose information (the test can fail)


def test_batch_and_pairwise_agree_with_single_calls():
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(8)
    particles, weights = _belief(rng, 250, 2)
    poses_a = rng.uniform(0.0, 40.0, (4, 2))
    poses_b = rng.uniform(0.0, 40.0, (3, 2))
    for method in ("fft", "quadrature"):
        singles = mutual_information_batch(
            sensor, poses_a[:, None, :], particles, weights, method=method
        )
        pairs = pairwise_mutual_information(
            sensor, poses_a, poses_b, particles, weights, method=method
        )
        assert singles.shape == (4,) and pairs.shape == (4, 3)
        for a in range(4):
            assert singles[a] == pytest.approx(
                mutual_information(sensor, poses_a[a : a + 1], particles, weights, method=method),
                abs=1e-9,
            )
            for b in range(3):
                pair = np.stack([poses_a[a], poses_b[b]])
                assert pairs[a, b] == pytest.approx(
                    mutual_information(sensor, pair, particles, weights, method=method), abs=1e-6
                )
    quantised_pairs = pairwise_mutual_information(
        BeaconSensor(), poses_a, poses_b, *_belief(rng, 100, 3), n_points=32
    )
    assert quantised_pairs.shape == (4, 3) and np.all(quantised_pairs >= -1e-12)


def test_monte_carlo_estimator_k3_and_k4():
    sensor = BearingSensor(0.3)
    rng = np.random.default_rng(9)
    particles, weights = _belief(rng, 200, 2)
    poses = np.array([[2.0, 2.0], [38.0, 3.0], [20.0, 38.0], [2.0, 30.0]])
    grid = mutual_information(
        sensor, poses[:3], particles, weights, method="quadrature", n_points=48
    )
    mc = mutual_information(
        sensor, poses[:3], particles, weights, method="monte_carlo", rng=rng, n_samples=8000
    )
    assert mc.method == "monte_carlo" and mc.stderr > 0
    assert abs(mc - grid) < 4 * mc.stderr + 0.005
    value, stderr = mutual_information(
        sensor, poses, particles, weights, rng=np.random.default_rng(1)
    ).as_tuple()
    assert select_method(sensor, 4) == "monte_carlo" and stderr > 0
    assert grid - 1e-3 < value  # a fourth observation cannot lose information (within MC error)
    again = mutual_information(sensor, poses, particles, weights, rng=np.random.default_rng(1))
    assert float(again) == value  # reproducible with the same seed
    values, stderrs = mutual_information_batch(
        sensor, poses[None], particles, weights, rng=np.random.default_rng(1), return_stderr=True
    )
    assert values[0] == value and stderrs[0] == stderr


def test_method_selection_and_forcing():
    assert select_method(BearingSensor(), 1) == "fft"
    assert select_method(RangeSensor(), 2) == "fft"
    assert select_method(BeaconSensor(), 2) == "quantised"
    assert select_method(BearingSensor(), 4) == "monte_carlo"
    rng = np.random.default_rng(11)
    particles, weights = _belief(rng, 50, 3)
    assert mutual_information(
        BeaconSensor(), [[1.0, 1.0]], particles, weights, method="quadrature"
    ).method == ("quadrature")
    with pytest.raises(TypeError, match="fft"):
        mutual_information(BeaconSensor(), [[1.0, 1.0]], particles, weights, method="fft")
    with pytest.raises(ValueError, match="rng"):
        mutual_information(BeaconSensor(), [[1.0, 1.0]], particles, weights, method="monte_carlo")
    with pytest.raises(ValueError, match="method"):
        mutual_information(BeaconSensor(), [[1.0, 1.0]], particles, weights, method="magic")


def test_input_validation():
    sensor = BearingSensor()
    particles = np.zeros((5, 2))
    weights = np.full(5, 0.2)
    with pytest.raises(ValueError, match="poses"):
        mutual_information(sensor, np.zeros(2), particles, weights)
    with pytest.raises(ValueError, match="weights"):
        mutual_information(sensor, [[1.0, 1.0]], particles, np.full(4, 0.25))
    with pytest.raises(ValueError, match="weights"):
        mutual_information(sensor, [[1.0, 1.0]], particles, -weights)
    with pytest.raises(ValueError, match="particles"):
        mutual_information(sensor, [[1.0, 1.0]], np.full((5, 2), np.nan), weights)
    with pytest.raises(ValueError, match="poses"):
        mutual_information_batch(sensor, np.zeros((3, 2)), particles, weights)


def test_mi_estimate_is_a_float_and_noise_scale():
    estimate = MIEstimate(0.5, 0.01, "monte_carlo")
    assert isinstance(estimate, float) and estimate + 1 == 1.5
    assert estimate.as_tuple() == (0.5, 0.01)
    assert noise_std(BearingSensor(0.1)) == pytest.approx(0.1, rel=1e-3)
    assert noise_std(RangeSensor(0.5)) == pytest.approx(0.5, rel=1e-3)


def _pair_sets(poses_a: np.ndarray, poses_b: np.ndarray) -> np.ndarray:
    """``(C * M, 2, 2)`` pose sets: every row of ``poses_a`` with every row of ``poses_b``."""
    a, b = np.broadcast_arrays(poses_a[:, None, :], poses_b[None, :, :])
    return np.stack([a, b], axis=2).reshape(-1, 2, 2)


@pytest.mark.parametrize(
    ("sensor", "centre", "spread", "pose_box"),
    [
        (BearingSensor(sigma=0.1), (20.0, 20.0), 1.0, (0.0, 10.0)),  # concentrated, no seam
        # Particles due west of every pose: bearings straddle the seam at +-pi.
        (BearingSensor(sigma=0.1), (5.0, 20.0), 0.8, (30.0, 38.0)),
        # Non-periodic range: particles close to the poses, predictions near the domain edge.
        (RangeSensor(sigma=0.5, max_range=60.0), (20.0, 20.0), 0.6, (19.0, 21.0)),
        (RangeSensor(sigma=0.5, max_range=60.0), (20.0, 20.0), 1.5, (0.0, 40.0)),
    ],
)
def test_windowed_pairs_equal_full_grid_and_quadrature(sensor, centre, spread, pose_box):
    from infoseek.planners.information import (
        PairwiseMIEvaluator,
        _fft_grid_points,
        _kernel,
        _predictions,
        _WindowSide,
    )

    rng = np.random.default_rng(11)
    particles = np.asarray(centre) + rng.normal(0.0, spread, (1500, 2))
    weights = rng.gamma(1.0, size=1500)
    weights /= weights.sum()
    poses_a = rng.uniform(*pose_box, (5, 2))
    poses_b = rng.uniform(*pose_box, (3, 2))
    if pose_box == (19.0, 21.0):  # a pose on top of the belief: ranges clamp at the low edge
        poses_a[0] = centre
    kernel = _kernel(sensor, _fft_grid_points(sensor, 2, None))
    side = _WindowSide(kernel, _predictions(sensor, poses_a, particles))
    assert side.fits and side.out < kernel.n_points  # the windowed path is the one tested
    windowed = pairwise_mutual_information(sensor, poses_a, poses_b, particles, weights)
    sets = _pair_sets(poses_a, poses_b)
    full = mutual_information_batch(sensor, sets, particles, weights, method="fft").reshape(5, 3)
    np.testing.assert_allclose(windowed, full, atol=1e-4, rtol=0)
    quadrature = mutual_information_batch(
        sensor, sets[:4], particles, weights, method="quadrature", n_points=256
    )
    np.testing.assert_allclose(windowed.ravel()[:4], quadrature, atol=1e-3, rtol=0)
    assert np.all(windowed > 0.02)  # informative pairs, so the comparison is not vacuous
    # The cached evaluator gives the same numbers, also when called again with seen poses.
    evaluator = PairwiseMIEvaluator(sensor, particles, weights)
    np.testing.assert_allclose(evaluator(poses_a, poses_b), windowed, atol=1e-12)
    np.testing.assert_allclose(evaluator(poses_a[1:3], poses_b), windowed[1:3], atol=1e-12)
    np.testing.assert_allclose(evaluator(poses_b[:1], poses_a).T[:, 0], windowed[:, 0], atol=1e-9)


def test_wide_belief_falls_back_to_the_full_circular_grid():
    from infoseek.planners.information import (
        PairwiseMIEvaluator,
        _fft_grid_points,
        _kernel,
        _predictions,
        _WindowSide,
    )

    sensor = BearingSensor(sigma=0.1)
    rng = np.random.default_rng(3)
    particles, weights = _belief(rng, 1200, 2)
    poses_a = np.array([[20.0, 18.0], [2.0, 2.0]])  # inside the belief: bearings span the circle
    poses_b = np.array([[21.0, 20.0], [38.0, 5.0], [10.0, 30.0]])
    kernel = _kernel(sensor, _fft_grid_points(sensor, 2, None))
    assert not _WindowSide(kernel, _predictions(sensor, poses_a, particles)).fits
    pairs = PairwiseMIEvaluator(sensor, particles, weights)(poses_a, poses_b)
    full = mutual_information_batch(
        sensor, _pair_sets(poses_a, poses_b), particles, weights, method="fft"
    ).reshape(2, 3)
    np.testing.assert_allclose(pairs, full, atol=1e-12)


def test_window_arc_contains_every_prediction_across_the_seam():
    from infoseek.planners.information import _kernel, _pose_windows

    sensor = BearingSensor(sigma=0.1)
    kernel = _kernel(sensor, 128)
    rng = np.random.default_rng(5)
    # Predictions clustered around +-pi (wrapped into [-pi, pi)), and one cluster mid-domain.
    seam = (np.pi + rng.normal(0.0, 0.2, 400) + np.pi) % (2 * np.pi) - np.pi
    middle = 0.3 + rng.normal(0.0, 0.2, 400)
    start, targets, weights, widths = _pose_windows(kernel, np.stack([seam, middle]))
    np.testing.assert_allclose(weights.sum(axis=2), 1.0, atol=1e-12)
    assert np.all(targets >= 0) and np.all(targets < widths[:, None, None])
    # The window is the short arc (~1.2 rad + guards), not the long way round.
    assert np.all(widths < 0.5 * kernel.n_points)
    # Window node x of pose p is global node (start + x) mod Q: stencil means reproduce the
    # predictions modulo the period.
    centre_nodes = (start[:, None] + (targets * weights).sum(axis=2)) * kernel.spacing
    residual = (centre_nodes + kernel.low - np.stack([seam, middle]) + np.pi) % (2 * np.pi)
    np.testing.assert_allclose(residual - np.pi, 0.0, atol=1e-9)


def test_window_of_an_arc_wider_than_half_a_period_starting_far_from_the_first_prediction():
    """Regression: bearing spreads over more than half the circle whose first prediction lies
    near the top of the arc left the lowest predictions' stencils at window node -1 (a crash in
    the windowed pair histogram, seen in trial pairwise/agents=3/791 of ``reproduce fig1``)."""
    from infoseek.planners.information import (
        _kernel,
        _pose_windows,
        _windowed_pair_entropies,
        _WindowSide,
    )

    sensor = BearingSensor(sigma=0.1)
    kernel = _kernel(sensor, 128)
    rng = np.random.default_rng(8)
    period = 2.0 * np.pi
    q = kernel.n_points
    # In grid nodes: one prediction 0.1 above a node k, the first one more than half a period
    # above it (so the arc measured from the first wraps it), the rest from k + 1.1 to k + 80
    # (an arc of 80 of 128 nodes: the window plus the kernel support fits in one period).
    bottom = rng.integers(0, q, 6) + 0.1
    nodes = bottom[:, None] + rng.uniform(1.0, 79.9, (6, 300))
    nodes[:, 0] = bottom + 0.5 * q + 0.4
    nodes[:, 1] = bottom
    nodes[:, 2] = bottom + 1.0  # the lowest of the rest: the window starts at node k
    predictions = (kernel.low + nodes * kernel.spacing + np.pi) % period - np.pi
    start, targets, weights, widths = _pose_windows(kernel, predictions)
    assert np.all(targets >= 0) and np.all(targets < widths[:, None, None])
    centre_nodes = (start[:, None] + (targets * weights).sum(axis=2)) * kernel.spacing
    residual = (centre_nodes + kernel.low - predictions + np.pi) % period - np.pi
    np.testing.assert_allclose(residual, 0.0, atol=1e-9)
    # The windowed pair entropies still equal the full circular grid.
    particle_weights = rng.gamma(1.0, size=300)
    particle_weights /= particle_weights.sum()
    partners = (rng.uniform(-0.4, 0.4, (2, 300)) + 1.0 + np.pi) % period - np.pi
    side_a, side_b = _WindowSide(kernel, predictions), _WindowSide(kernel, partners)
    assert side_a.fits and side_b.fits
    windowed = _windowed_pair_entropies(kernel, side_a, side_b, particle_weights)
    index_a, weight_a = kernel.assign(predictions)
    index_b, weight_b = kernel.assign(partners)
    full, _ = kernel.entropies(
        [(index_a[:, None], weight_a[:, None]), (index_b[None], weight_b[None])],
        particle_weights,
    )
    np.testing.assert_allclose(windowed, full, atol=1e-4, rtol=0)
