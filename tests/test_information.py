"""The MI module's public functions, registry, errors and the FFT estimator's grid machinery.

Accuracy of every estimator against references is in ``tests/test_estimators.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import infoseek.envs
from infoseek.envs.sensors import BeaconSensor, BearingSensor, RangeSensor
from infoseek.planners import PairwiseNodePlanner, SingleNodePlanner
from infoseek.planners.information import (
    ESTIMATORS,
    METHODS,
    MIEstimate,
    make_estimator,
    mutual_information,
    mutual_information_batch,
    noise_std,
    pairwise_mutual_information,
    select_method,
)
from infoseek.planners.information.noise_kernel import NoiseKernel
from infoseek.planners.information.windows import (
    WindowSide,
    full_grid_pair_entropies,
    pose_windows,
    windowed_pair_entropies,
)


def _belief(rng: np.random.Generator, n: int, target_dim: int) -> tuple[np.ndarray, np.ndarray]:
    """A non-uniform particle set: two blobs in the 40 x 40 square, random weights."""
    centres = np.array([[14.0, 22.0], [27.0, 15.0]])
    xy = centres[rng.integers(0, 2, n)] + rng.normal(0.0, [2.5, 4.0], (n, 2))
    xy = np.clip(xy, 0.5, 39.5)
    if target_dim == 3:
        xy = np.column_stack([xy, rng.uniform(0.0, 2.0 * np.pi, n)])
    weights = rng.gamma(0.7, size=n)
    return xy, weights / weights.sum()


def _pair_sets(poses_a: np.ndarray, poses_b: np.ndarray) -> np.ndarray:
    """``(C * M, 2, 2)`` pose sets: every row of ``poses_a`` with every row of ``poses_b``."""
    a, b = np.broadcast_arrays(poses_a[:, None, :], poses_b[None, :, :])
    return np.stack([a, b], axis=2).reshape(-1, 2, 2)


# ------------------------------------------------------------------------ registry and errors
def test_method_selection_and_forcing():
    assert set(METHODS) == {"auto", *ESTIMATORS}
    assert select_method(BearingSensor(), 1) == "fft"
    assert select_method(RangeSensor(), 2) == "fft"
    assert select_method(BeaconSensor(), 2) == "fourier"
    assert select_method(BeaconSensor().with_max_snr(5.0), 1) == "fourier"
    assert select_method(BearingSensor(), 4) == "monte_carlo"
    rng = np.random.default_rng(11)
    particles, weights = _belief(rng, 50, 3)
    forced = mutual_information(
        BeaconSensor(), [[1.0, 1.0]], particles, weights, method="quadrature"
    )
    assert forced.method == "quadrature"


def test_bad_estimator_requests_give_clear_errors():
    rng = np.random.default_rng(11)
    particles, weights = _belief(rng, 50, 3)
    with pytest.raises(ValueError, match=r"method must be one of .*'fft'.*'fourier'"):
        mutual_information(BeaconSensor(), [[1.0, 1.0]], particles, weights, method="magic")
    with pytest.raises(ValueError, match="method must be one of"):
        make_estimator("magic", BeaconSensor())
    # an estimator forced on a sensor it cannot serve: TypeError naming the missing methods
    with pytest.raises(TypeError, match=r"'fft' needs sensor method\(s\) \['predict'"):
        make_estimator("fft", BeaconSensor())
    with pytest.raises(TypeError, match="kernel_parameters"):
        make_estimator("fourier", RangeSensor())
    with pytest.raises(ValueError, match="rng"):
        mutual_information(BeaconSensor(), [[1.0, 1.0]], particles, weights, method="monte_carlo")
    with pytest.raises(ValueError, match="at most 3 joint observations"):
        mutual_information(BearingSensor(), np.ones((4, 2)), particles, weights, method="fft")
    with pytest.raises(ValueError, match="n_points"):
        make_estimator("quadrature", BearingSensor(), n_points=1)
    with pytest.raises(ValueError, match="max_shape"):
        make_estimator("fourier", BeaconSensor(), max_shape=-1.0)


def test_planner_options_are_validated_when_the_planner_is_built():
    env = infoseek.envs.make("beacon_v0", n_agents=2, n_particles=100)
    with pytest.raises(ValueError, match=r"mi_method must be one of .*'fourier'"):
        SingleNodePlanner.from_env(env, mi_method="fourrier")
    with pytest.raises(TypeError, match="predict"):
        SingleNodePlanner.from_env(env, mi_method="fft")
    bearings = infoseek.envs.make("bearings_v0", n_agents=2, n_particles=100)
    with pytest.raises(ValueError, match="quadrature_points"):
        PairwiseNodePlanner.from_env(bearings, quadrature_points=1)


def test_monte_carlo_planner_draws_from_its_own_generator():
    """mi_method='monte_carlo' works in act(): the planner passes its own generator, so two
    planners with the same seed make the same decisions."""
    env = infoseek.envs.make("bearings_v0", n_agents=2, n_particles=100, belief_in_infos=True)
    controls = []
    for _ in range(2):
        observations, infos = env.reset(seed=4)
        planner = SingleNodePlanner.from_env(
            env, mi_method="monte_carlo", n_planning=80, seed=9, refine=False
        )
        actions = planner.act(observations, infos)
        controls.append(np.concatenate([actions[a] for a in env.agents]))
    np.testing.assert_array_equal(controls[0], controls[1])


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
    with pytest.raises(ValueError, match="poses_b"):
        pairwise_mutual_information(sensor, np.zeros((3, 2)), np.zeros(2), particles, weights)


def test_mi_estimate_is_a_float_and_noise_scale():
    estimate = MIEstimate(0.5, 0.01, "monte_carlo")
    assert isinstance(estimate, float) and estimate + 1 == 1.5
    assert estimate.as_tuple() == (0.5, 0.01)
    assert noise_std(BearingSensor(0.1)) == pytest.approx(0.1, rel=1e-3)
    assert noise_std(RangeSensor(0.5)) == pytest.approx(0.5, rel=1e-3)


# ------------------------------------------------------------------------- basic properties
@pytest.mark.parametrize(
    ("sensor", "target_dim"),
    [(BearingSensor(0.1), 2), (RangeSensor(0.5), 2), (BeaconSensor().with_max_snr(5.0), 3)],
    ids=["bearing", "range", "beacon"],
)
def test_bounds_and_redundancy(sensor, target_dim):
    rng = np.random.default_rng(50)
    particles, weights = _belief(rng, 300, target_dim)
    pose = np.array([[18.0, 12.0]])
    single = mutual_information(sensor, pose, particles, weights)
    twice = mutual_information(sensor, np.vstack([pose, pose]), particles, weights)
    assert single > 0.0
    assert float(single) == pytest.approx(single.entropy - single.conditional_entropy, abs=1e-12)
    assert single <= twice <= 2.0 * single + 1e-9  # a repeated observation helps, sub-additively
    # H(z | theta) of an additive sensor: k times the noise entropy
    if target_dim == 2:
        gaussian = 0.5 * math.log(2 * math.pi * math.e) + math.log(noise_std(sensor))
        assert single.conditional_entropy == pytest.approx(gaussian, abs=2e-3)


def test_mi_is_zero_for_uninformative_sensor_and_positive_otherwise():
    sensor = BearingSensor(0.2)
    rng = np.random.default_rng(6)
    t = rng.uniform(0.0, 20.0, 200)
    particles = np.column_stack([2.0 + t, 2.0 + t])  # all on one ray from (2, 2)
    weights = np.full(200, 1.0 / 200)
    for method in ("fft", "fourier", "quadrature"):
        assert (
            abs(mutual_information(sensor, [[1.0, 1.0]], particles, weights, method=method)) < 1e-3
        )
        assert mutual_information(sensor, [[30.0, 2.0]], particles, weights, method=method) > 0.5


def test_quantised_is_monotone_under_nested_refinement_and_tends_to_continuous():
    sensor = BeaconSensor().with_max_snr(5.0)
    rng = np.random.default_rng(7)
    particles, weights = _belief(rng, 300, 3)
    poses = np.array([[20.0, 29.0]])
    continuous = mutual_information(sensor, poses, particles, weights, method="fourier")
    values = [
        mutual_information(sensor, poses, particles, weights, method="quantised", n_points=q)
        for q in (4, 8, 16, 32, 64, 128, 256)
    ]
    assert all(v.method == "quantised" for v in values)
    assert all(b >= a - 1e-9 for a, b in zip(values, values[1:], strict=False))
    assert values[-1] <= continuous + 1e-6
    assert continuous - values[-1] < 0.01


def test_batch_and_pairwise_agree_with_single_calls():
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(8)
    particles, weights = _belief(rng, 250, 2)
    poses_a = rng.uniform(0.0, 40.0, (4, 2))
    poses_b = rng.uniform(0.0, 40.0, (3, 2))
    for method in ("fft", "fourier", "quadrature"):
        singles = mutual_information_batch(
            sensor, poses_a[:, None, :], particles, weights, method=method
        )
        pairs = pairwise_mutual_information(
            sensor, poses_a, poses_b, particles, weights, method=method
        )
        for a in range(4):
            one = mutual_information(sensor, poses_a[a : a + 1], particles, weights, method=method)
            assert singles[a] == pytest.approx(float(one), abs=1e-9)
            for b in range(3):
                pair = np.stack([poses_a[a], poses_b[b]])
                joint = mutual_information(sensor, pair, particles, weights, method=method)
                assert pairs[a, b] == pytest.approx(float(joint), abs=1e-6)


def test_monte_carlo_estimator_k3_and_k4():
    sensor = BearingSensor(0.3)
    rng = np.random.default_rng(9)
    particles, weights = _belief(rng, 200, 2)
    poses = np.array([[2.0, 2.0], [38.0, 3.0], [20.0, 38.0]])
    grid = mutual_information(sensor, poses, particles, weights, method="fft")
    mc = mutual_information(
        sensor, poses, particles, weights, method="monte_carlo", n_samples=20000, rng=rng
    )
    assert abs(float(mc) - float(grid)) < 5 * mc.stderr + 0.01
    poses4 = np.vstack([poses, [[2.0, 38.0]]])
    value, stderr = mutual_information(
        sensor, poses4, particles, weights, rng=np.random.default_rng(1)
    ).as_tuple()
    assert select_method(sensor, 4) == "monte_carlo" and stderr > 0 and value > float(grid)
    again = mutual_information(sensor, poses4, particles, weights, rng=np.random.default_rng(1))
    assert float(again) == value  # same generator state, same estimate


def test_fft_single_path_has_no_nearest_node_rounding_error():
    """The single-observation FFT path spreads predictions with the quadratic stencil: on small
    beliefs (N = 300, where rounding predictions to nodes cost up to 1.1e-3 nats) the error
    against a fine quadrature stays near 1e-4 over many random configurations."""
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(12)
    fft = make_estimator("fft", sensor)
    fine = make_estimator("quadrature", sensor, n_points=2048)
    errors = []
    for _ in range(25):
        centre = rng.uniform(10.0, 30.0, 2)
        particles = centre + rng.normal(0.0, rng.uniform(0.3, 3.0), (300, 2))
        weights = rng.gamma(1.0, size=300)
        poses = rng.uniform(0.0, 40.0, (4, 2))
        errors.append(
            fft.bind(particles, weights).single(poses) - fine.bind(particles, weights).single(poses)
        )
    errors = np.concatenate(errors)
    assert np.max(np.abs(errors)) < 4e-4
    assert abs(np.mean(errors)) < 1e-4


# ----------------------------------------------------------------------- windowed FFT pairs
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
    rng = np.random.default_rng(11)
    particles = np.asarray(centre) + rng.normal(0.0, spread, (1500, 2))
    weights = rng.gamma(1.0, size=1500)
    weights /= weights.sum()
    poses_a = rng.uniform(*pose_box, (5, 2))
    poses_b = rng.uniform(*pose_box, (3, 2))
    if pose_box == (19.0, 21.0):  # a pose on top of the belief: ranges clamp at the low edge
        poses_a[0] = centre
    estimator = make_estimator("fft", sensor)
    mi = estimator.bind(particles, weights)
    side = WindowSide.from_predictions(
        estimator.kernel, estimator.predictions(mi, poses_a).astype(np.float64)
    )
    assert side.fits and side.out < estimator.n_points  # the windowed path is the one tested
    windowed = mi.pairs(poses_a, poses_b)
    full = full_grid_pair_entropies(
        estimator.kernel,
        estimator.predictions(mi, poses_a).astype(np.float64),
        estimator.predictions(mi, poses_b).astype(np.float64),
        mi.weights,
    )
    np.testing.assert_allclose(windowed, full - 2 * estimator.kernel.entropy, atol=1e-6, rtol=0)
    quadrature = mutual_information_batch(
        sensor,
        _pair_sets(poses_a, poses_b)[:4],
        particles,
        weights,
        method="quadrature",
        n_points=512,
    )
    np.testing.assert_allclose(windowed.ravel()[:4], quadrature, atol=1e-3, rtol=0)
    assert np.all(windowed > 0.02)  # informative pairs, so the comparison is not vacuous


def test_wide_belief_falls_back_to_the_full_circular_grid():
    sensor = BearingSensor(sigma=0.1)
    rng = np.random.default_rng(3)
    particles, weights = _belief(rng, 1200, 2)
    poses_a = np.array([[20.0, 18.0], [2.0, 2.0]])  # inside the belief: bearings span the circle
    poses_b = np.array([[21.0, 20.0], [38.0, 5.0], [10.0, 30.0]])
    estimator = make_estimator("fft", sensor)
    mi = estimator.bind(particles, weights)
    predictions = estimator.predictions(mi, poses_a).astype(np.float64)
    assert not WindowSide.from_predictions(estimator.kernel, predictions).fits
    quadrature = mutual_information_batch(
        sensor,
        _pair_sets(poses_a, poses_b),
        particles,
        weights,
        method="quadrature",
        n_points=512,
    ).reshape(2, 3)
    np.testing.assert_allclose(mi.pairs(poses_a, poses_b), quadrature, atol=1e-3)


def test_window_arc_contains_every_prediction_across_the_seam():
    sensor = BearingSensor(sigma=0.1)
    kernel = NoiseKernel(sensor, 128)
    rng = np.random.default_rng(5)
    # Predictions clustered around +-pi (wrapped into [-pi, pi)), and one cluster mid-domain.
    seam = (np.pi + rng.normal(0.0, 0.2, 400) + np.pi) % (2 * np.pi) - np.pi
    middle = 0.3 + rng.normal(0.0, 0.2, 400)
    start, targets, weights, widths = pose_windows(kernel, np.stack([seam, middle]))
    np.testing.assert_allclose(weights.sum(axis=2), 1.0, atol=1e-6)  # float32 weights
    assert np.all(targets >= 0) and np.all(targets < widths[:, None, None])
    # The window is the short arc (~1.2 rad + guards), not the long way round.
    assert np.all(widths < 0.5 * kernel.n_points)
    # Window node x of pose p is global node (start + x) mod Q: stencil means reproduce the
    # predictions modulo the period.
    centre_nodes = (start[:, None] + (targets * weights).sum(axis=2)) * kernel.spacing
    residual = (centre_nodes + kernel.low - np.stack([seam, middle]) + np.pi) % (2 * np.pi)
    np.testing.assert_allclose(residual - np.pi, 0.0, atol=2e-6)  # float32 positions


def test_window_of_an_arc_wider_than_half_a_period_starting_far_from_the_first_prediction():
    """Regression: bearing spreads over more than half the circle whose first prediction lies
    near the top of the arc left the lowest predictions' stencils at window node -1 (a crash in
    the windowed pair histogram, seen in trial pairwise/agents=3/791 of ``reproduce fig1``)."""
    sensor = BearingSensor(sigma=0.1)
    kernel = NoiseKernel(sensor, 128)
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
    start, targets, weights, widths = pose_windows(kernel, predictions)
    assert np.all(targets >= 0) and np.all(targets < widths[:, None, None])
    centre_nodes = (start[:, None] + (targets * weights).sum(axis=2)) * kernel.spacing
    residual = (centre_nodes + kernel.low - predictions + np.pi) % period - np.pi
    np.testing.assert_allclose(residual, 0.0, atol=2e-6)  # float32 positions
    # The windowed pair entropies still equal the full circular grid.
    particle_weights = rng.gamma(1.0, size=300)
    particle_weights /= particle_weights.sum()
    partners = (rng.uniform(-0.4, 0.4, (2, 300)) + 1.0 + np.pi) % period - np.pi
    side_a = WindowSide.from_predictions(kernel, predictions)
    side_b = WindowSide.from_predictions(kernel, partners)
    assert side_a.fits and side_b.fits
    windowed = windowed_pair_entropies(kernel, side_a, side_b, particle_weights)
    full = full_grid_pair_entropies(kernel, predictions, partners, particle_weights)
    np.testing.assert_allclose(windowed, full, atol=1e-4, rtol=0)


def _near_beacon_belief(n: int = 500) -> tuple[np.ndarray, np.ndarray]:
    """A belief concentrated ~3 units from a receiver at (5, 5): the exact beacon's SNR there
    reaches hundreds, beyond the 64 the Fourier table resolves by default."""
    rng = np.random.default_rng(11)
    particles = np.column_stack(
        [rng.normal(8.0, 0.5, n), rng.normal(6.0, 0.5, n), rng.normal(1.0, 0.2, n)]
    )
    return particles, np.full(n, 1.0 / n)


def test_exact_beacon_mi_beyond_the_resolved_snr_is_marked_and_warned_as_a_lower_bound():
    """Issue 29: the auto estimate for the exact receiver near the beacon was silently low."""
    from infoseek.planners.information.base import MILowerBoundWarning

    sensor = BeaconSensor(moment=1000.0, noise_std=1.0)
    particles, weights = _near_beacon_belief()
    pose = np.array([[5.0, 5.0]])
    with pytest.warns(MILowerBoundWarning, match="lower bound") as caught:
        value = mutual_information(sensor, pose, particles, weights)
    assert caught[0].filename == __file__  # attributed to the caller
    _, shapes = sensor.kernel_parameters(pose, particles)  # brute force: the capped weight
    assert value.lower_bound and value.unresolved_mass == pytest.approx(
        float(weights[shapes[0] > 64.0].sum())
    )
    assert 0.1 < value.unresolved_mass < 1.0
    reference = mutual_information(
        sensor,
        pose,
        particles,
        weights,
        method="monte_carlo",
        n_samples=20_000,
        rng=np.random.default_rng(0),
    )
    assert float(value) < float(reference) - 3.0 * reference.stderr  # truly low, as marked
    with pytest.warns(MILowerBoundWarning):
        pairwise_mutual_information(sensor, pose, [[7.0, 4.0]], particles, weights)


def test_a_resolved_beacon_mi_is_not_marked_and_does_not_warn():
    import warnings

    particles, weights = _near_beacon_belief()
    floored = BeaconSensor(moment=1000.0, noise_std=1.0, max_snr=5.0)  # beacon_v0's filter
    far = particles + np.array([25.0, 25.0, 0.0])  # SNR below 64 everywhere
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for sensor, belief in ((floored, particles), (BeaconSensor(1000.0, 1.0), far)):
            value = mutual_information(sensor, [[5.0, 5.0]], belief, weights)
            assert not value.lower_bound and value.unresolved_mass == 0.0
        assert mutual_information(
            floored, [[5.0, 5.0]], particles, weights, method="quantised"
        ).lower_bound
