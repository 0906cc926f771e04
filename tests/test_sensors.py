"""Tests for infoseek.envs.sensors: samples vs likelihood, normalisation, exact bin masses,
the beacon's dipole geometry, broadcasting, validation and determinism."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import quad
from scipy.special import logsumexp, ndtr

from infoseek.envs.sensors import (
    SENSOR_REGISTRY,
    AdditiveNoiseSensor,
    BeaconSensor,
    BearingSensor,
    ObservationDomain,
    RangeSensor,
    Sensor,
    make_sensor,
)

# (sensor, pose, target) cases covering sharp and flat likelihoods and the wrap-around.
CASES = [
    pytest.param(BearingSensor(0.1), (0.0, 0.0), (10.0, 5.0), id="bearing-sharp"),
    pytest.param(BearingSensor(0.1), (0.0, 0.0), (-10.0, -0.05), id="bearing-at-wrap"),
    pytest.param(BearingSensor(1.0), (3.0, -2.0), (-5.0, 7.0), id="bearing-wide"),
    pytest.param(BearingSensor(3.0), (0.0, 0.0), (1.0, 1.0), id="bearing-fourier"),
    pytest.param(RangeSensor(0.5), (0.0, 0.0), (12.0, 16.0), id="range"),
    pytest.param(RangeSensor(2.0, max_range=30.0), (5.0, 5.0), (5.0, 5.5), id="range-near-zero"),
    pytest.param(BeaconSensor(), (4.0, 1.0), (0.0, 0.0, 0.3), id="beacon-near-sharp"),
    pytest.param(BeaconSensor(), (10.0, 3.0), (0.0, 0.0, 2.0), id="beacon-medium"),
    pytest.param(BeaconSensor(), (35.0, 30.0), (0.0, 0.0, 2.0), id="beacon-far-flat"),
]


def density_on_grid(sensor, pose, target, n_points: int = 200_001):
    """Grid over the observation domain and exp(log_likelihood) on it."""
    low, high = sensor.domain.low[0], sensor.domain.high[0]
    grid = np.linspace(low, high, n_points)
    logp = sensor.log_likelihood(grid[:, None], np.asarray(pose), np.asarray(target)[None, :])
    return grid, np.exp(logp[:, 0])


def cdf_from_density(grid, density):
    """Cumulative trapezoid integral of the density, as a callable CDF."""
    steps = 0.5 * (density[1:] + density[:-1]) * np.diff(grid)
    cumulative = np.concatenate([[0.0], np.cumsum(steps)])
    return lambda x: np.interp(x, grid, cumulative)


def target_particles(sensor, target):
    return np.asarray(target, dtype=float)[None, :]


# --------------------------------------------------------------------------------------------
# Samples agree with the likelihood
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("sensor", "pose", "target"), CASES)
def test_samples_follow_likelihood_ks(sensor, pose, target):
    """KS test of many samples against the CDF obtained by integrating exp(log_likelihood)."""
    rng = np.random.default_rng(12345)
    n = 4000
    poses = np.broadcast_to(np.asarray(pose), (n, 2))
    z = sensor.sample(poses, np.asarray(target), rng)
    assert z.shape == (n, 1)
    low, high = sensor.domain.low[0], sensor.domain.high[0]
    if sensor.domain.periodic[0]:
        assert np.all((z >= low) & (z < high))
    grid, density = density_on_grid(sensor, pose, target)
    result = stats.kstest(z[:, 0], cdf_from_density(grid, density))
    assert result.pvalue > 1e-3, result


@pytest.mark.parametrize(("sensor", "pose", "target"), CASES)
def test_samples_follow_bin_probabilities_chi2(sensor, pose, target):
    """Chi-square test of binned samples against bin_probabilities (merged to >= 5 expected)."""
    rng = np.random.default_rng(777)
    n = 6000
    z = sensor.sample(np.broadcast_to(np.asarray(pose), (n, 2)), np.asarray(target), rng)[:, 0]
    edges = np.linspace(sensor.domain.low[0], sensor.domain.high[0], 401)
    probs = sensor.bin_probabilities(edges, np.asarray(pose), target_particles(sensor, target))[0]
    counts = np.histogram(z, bins=edges)[0]
    # Merge consecutive bins until each carries >= 5 expected counts.
    merged_expected, merged_counts, acc_e, acc_c = [], [], 0.0, 0
    for e, c in zip(probs * n, counts, strict=True):
        acc_e += e
        acc_c += c
        if acc_e >= 5.0:
            merged_expected.append(acc_e)
            merged_counts.append(acc_c)
            acc_e, acc_c = 0.0, 0
    merged_expected[-1] += acc_e
    merged_counts[-1] += acc_c
    expected = np.asarray(merged_expected)
    observed = np.asarray(merged_counts)
    assert observed.sum() == n
    if len(expected) > 1:
        result = stats.chisquare(observed, expected * n / expected.sum())
        assert result.pvalue > 1e-3, result


def test_goodness_of_fit_detects_a_wrong_model():
    """The KS check has power: bearings with sigma 0.1 are rejected under sigma 0.15."""
    rng = np.random.default_rng(5)
    z = BearingSensor(0.1).sample(np.zeros((4000, 2)), np.array([10.0, 5.0]), rng)[:, 0]
    grid, density = density_on_grid(BearingSensor(0.15), (0.0, 0.0), (10.0, 5.0))
    assert stats.kstest(z, cdf_from_density(grid, density)).pvalue < 1e-6


# --------------------------------------------------------------------------------------------
# Normalisation and exact bin masses
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("sensor", "pose", "target"), CASES)
def test_likelihood_integrates_to_one(sensor, pose, target):
    grid, density = density_on_grid(sensor, pose, target)
    if sensor.domain.periodic[0]:
        # Periodic rectangle rule (drop the duplicated endpoint): spectrally accurate.
        total = density[:-1].sum() * (grid[1] - grid[0])
    else:
        total = np.trapezoid(density, grid)
    assert total == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize(("sensor", "pose", "target"), CASES)
def test_bin_probabilities_match_integrated_density(sensor, pose, target):
    edges = np.linspace(sensor.domain.low[0], sensor.domain.high[0], 13)
    probs = sensor.bin_probabilities(edges, np.asarray(pose), target_particles(sensor, target))[0]
    assert probs.shape == (12,)
    particles = target_particles(sensor, target)

    def density(z):
        return math.exp(sensor.log_likelihood(np.array([[z]]), np.asarray(pose), particles)[0, 0])

    grid, dens = density_on_grid(sensor, pose, target)
    mode = grid[np.argmax(dens)]
    expected = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        points = [mode] if a < mode < b else None
        expected.append(quad(density, a, b, points=points, limit=400, epsabs=1e-13)[0])
    np.testing.assert_allclose(probs, expected, atol=1e-10)
    if sensor.domain.periodic[0]:
        assert probs.sum() == pytest.approx(1.0, abs=1e-12)
    else:
        assert probs.sum() == pytest.approx(1.0, abs=1e-8)


@pytest.mark.parametrize("sigma", [0.05, 0.1, 0.5, 0.97, 1.5, 1.99, 2.0, 3.0, 10.0])
def test_wrapped_normal_matches_brute_force_image_sum(sigma):
    sensor = BearingSensor(sigma)
    r = np.linspace(-math.pi, math.pi, 2001)
    k = np.arange(-300, 301)
    brute = logsumexp(-((r[:, None] + 2 * math.pi * k) ** 2) / (2 * sigma**2), axis=1) - math.log(
        sigma * math.sqrt(2 * math.pi)
    )
    got = sensor.noise_log_density(r[:, None])
    np.testing.assert_allclose(got, brute, rtol=1e-13, atol=1e-13)
    # Image-sum bin masses against the brute-force sum of normal CDF differences.
    edges = np.linspace(-math.pi, math.pi, 9)
    mu = 2.5
    brute_bins = (
        ndtr((edges[1:, None] - mu + 2 * math.pi * k) / sigma)
        - ndtr((edges[:-1, None] - mu + 2 * math.pi * k) / sigma)
    ).sum(axis=1)
    target = np.array([[math.cos(mu), math.sin(mu)]])
    got_bins = sensor.bin_probabilities(edges, np.zeros(2), target)[0]
    np.testing.assert_allclose(got_bins, brute_bins, atol=1e-13)


@pytest.mark.parametrize("distance", [0.5, 0.2, 0.1])
def test_beacon_bins_reach_gaussian_limit(distance):
    """For rho ~ 1e4..1e6 the folded bins match normal CDF differences across the peak.

    Edges a few 1/rho apart carry an absolute rounding error of ~eps in angle, i.e. ~rho * eps in
    standardised units, which bounds the attainable agreement.
    """
    sensor = BeaconSensor()
    pose = np.array([distance * math.cos(0.7), distance * math.sin(0.7)])
    particle = np.array([[0.0, 0.0, 0.4]])
    h = sensor.field(pose, particle[0])
    rho = np.hypot(*h) / sensor.noise_std
    theta = math.atan2(h[1], h[0]) % math.pi
    width = 6.0 / rho
    edges = np.concatenate([[0.0], theta + width * np.linspace(-1, 1, 11), [math.pi]])
    probs = sensor.bin_probabilities(edges, pose, particle)[0]
    gauss = np.diff(ndtr(rho * np.sin(np.clip(edges - theta, -math.pi / 2, math.pi / 2))))
    gauss[0] += ndtr(-rho * math.sin(theta))  # everything left of the first inner edge
    assert rho > 1e4
    np.testing.assert_allclose(probs, gauss, atol=max(1e-10, 20 * rho * np.finfo(float).eps))
    assert probs.sum() == pytest.approx(1.0, abs=1e-12)


def test_beacon_likelihood_finite_and_warning_free_near_antenna():
    sensor = BeaconSensor()
    particles = np.array([[0.0, 0.0, 0.3], [1.0, 1.0, 2.0], [1e-4, 0.0, 1.0]])
    poses = np.array([[0.0, 0.0], [1e-9, 0.0], [0.5, 0.5], [1.0, 1.0], [39.0, 39.0]])
    z = np.linspace(0.0, math.pi, 7, endpoint=False)[:, None, None]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        logp = sensor.log_likelihood(z, poses[None, :, :], particles)
        bins = sensor.bin_probabilities(np.linspace(0, math.pi, 17), poses, particles)
        samples = sensor.sample(poses, particles[0], np.random.default_rng(0))
    assert logp.shape == (7, 5, 3)
    assert np.all(np.isfinite(logp))
    assert np.all(np.isfinite(bins)) and np.allclose(bins.sum(-1), 1.0, atol=1e-12)
    assert np.all((samples >= 0) & (samples < math.pi))


def test_beacon_log_density_accurate_for_huge_rho():
    """Near the peak with rho = 1e6 the log density equals the Gaussian limit log-density."""
    sensor = BeaconSensor(moment=1e6, noise_std=1.0)
    particle = np.array([[0.0, 0.0, 0.0]])
    pose = np.array([1.0, 0.0])  # field along +x with |H| = 2e6
    rho = 2e6
    delta = np.array([0.0, 1e-7, -3e-7, 2e-6])
    got = sensor.log_likelihood(delta[:, None], pose, particle)[:, 0]
    # Exact folded density with a -> rho cos(delta) ~ rho: log(rho cos d * phi(rho sin d)).
    expected = (
        np.log(rho * np.cos(delta)) - 0.5 * (rho * np.sin(delta)) ** 2 - 0.5 * math.log(2 * math.pi)
    )
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_beacon_flat_far_and_sharp_near():
    sensor = BeaconSensor()
    z = np.linspace(0, math.pi, 721)[:, None]
    far = np.exp(sensor.log_likelihood(z, np.array([35.0, 30.0]), np.array([[0.0, 0.0, 1.0]])))
    near = np.exp(sensor.log_likelihood(z, np.array([3.0, 1.0]), np.array([[0.0, 0.0, 1.0]])))
    assert np.all(np.abs(far * math.pi - 1.0) < 0.05)
    assert near.max() * math.pi > 20.0


# --------------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------------


def test_beacon_direction_matches_vector_dipole_formula():
    """Noise-free field direction vs H = m (3 (p.r_hat) r_hat - p) / r^3, modulo pi."""
    rng = np.random.default_rng(3)
    moment = 750.0
    sensor = BeaconSensor(moment=moment)
    poses = rng.uniform(-20, 20, size=(200, 2))
    targets = np.column_stack([rng.uniform(-20, 20, size=(200, 2)), rng.uniform(0, 2 * np.pi, 200)])
    offset = poses - targets[:, :2]
    r = np.linalg.norm(offset, axis=1, keepdims=True)
    r_hat = offset / r
    p = np.column_stack([np.cos(targets[:, 2]), np.sin(targets[:, 2])])
    expected = moment * (3 * np.sum(p * r_hat, axis=1, keepdims=True) * r_hat - p) / r**3
    field = sensor.field(poses, targets)
    np.testing.assert_allclose(field, expected, rtol=1e-10, atol=1e-14)
    # The peak of the likelihood sits at the field direction modulo pi.
    expected_dir = np.arctan2(expected[:, 1], expected[:, 0]) % np.pi
    for i in range(5):
        z = np.array([[expected_dir[i]], [(expected_dir[i] + 0.3) % np.pi]])
        logp = sensor.log_likelihood(z, poses[i], targets[i : i + 1])[:, 0]
        assert logp[0] > logp[1]


@pytest.mark.parametrize("max_snr", [5.0, math.inf])
def test_beacon_kernel_parameters_are_the_scaled_fields_direction_and_norm(max_snr: float) -> None:
    """Centre and shape against the 2-D dipole field written from its formula, for a
    ``(2, 3)`` batch of poses and particles near and far (one at a receiver's ``1e-4``)."""
    rng = np.random.default_rng(12)
    sensor = BeaconSensor(moment=1000.0, noise_std=2.0, max_snr=max_snr)
    poses = rng.uniform(0.0, 40.0, (2, 3, 2))
    particles = np.column_stack(
        [rng.uniform(0.0, 40.0, 30), rng.uniform(0.0, 40.0, 30), rng.uniform(0, 2 * math.pi, 30)]
    )
    particles[:10, :2] = poses[0, 0] + rng.normal(0.0, 1.0, (10, 2))
    particles[10, :2] = poses[1, 2] + [1e-4, 0.0]
    centre, shape = sensor.kernel_parameters(poses, particles)
    assert centre.shape == shape.shape == (2, 3, 30)
    assert np.all((centre >= 0.0) & (centre < math.pi))
    for index in np.ndindex(2, 3):
        for n in range(30):
            offset = poses[index] - particles[n, :2]  # antenna -> receiver
            r = math.hypot(*offset)
            e_r = offset / r
            axis = np.array([math.cos(particles[n, 2]), math.sin(particles[n, 2])])
            mu = 1000.0 / max(r, 1e-3) ** 3 * (3.0 * (axis @ e_r) * e_r - axis) / 2.0
            mu = mu * min(1.0, max_snr / math.hypot(*mu))
            np.testing.assert_allclose(shape[index][n], math.hypot(*mu), rtol=1e-12)
            direction = math.atan2(mu[1], mu[0]) % math.pi  # the field line: an axis
            gap = abs(centre[index][n] - direction)
            assert min(gap, math.pi - gap) < 1e-12


def test_bearing_and_range_predictions():
    poses = np.array([[0.0, 0.0], [1.0, 1.0]])
    particles = np.array([[3.0, 4.0], [-1.0, 0.0], [1.0, 1.0 - 1e-9]])
    bearing = BearingSensor().predict(poses, particles)[..., 0]
    expected = np.arctan2(particles[:, 1] - poses[:, 1, None], particles[:, 0] - poses[:, 0, None])
    expected = np.where(expected >= np.pi, expected - 2 * np.pi, expected)
    np.testing.assert_allclose(bearing, expected)
    assert np.all((bearing >= -np.pi) & (bearing < np.pi))  # (-1, 0) from origin: pi -> -pi
    assert bearing[0, 1] == pytest.approx(-np.pi)
    ranges = RangeSensor().predict(poses, particles)[..., 0]
    np.testing.assert_allclose(ranges[0, 0], 5.0)
    np.testing.assert_allclose(
        ranges, np.linalg.norm(particles[None] - poses[:, None], axis=-1), rtol=1e-15
    )


@pytest.mark.parametrize("sensor", [BearingSensor(0.2), BearingSensor(2.5), RangeSensor(0.7)])
def test_additive_noise_structure(sensor):
    assert isinstance(sensor, AdditiveNoiseSensor)
    rng = np.random.default_rng(9)
    poses = rng.uniform(-10, 10, size=(6, 2))
    particles = rng.uniform(-10, 10, size=(50, 2))
    z = rng.uniform(-3, 3, size=(6, 1))
    direct = sensor.log_likelihood(z, poses, particles)
    residual = z[:, None, :] - sensor.predict(poses, particles)
    np.testing.assert_allclose(direct, sensor.noise_log_density(residual), rtol=1e-12, atol=1e-12)


# --------------------------------------------------------------------------------------------
# Broadcasting, validation, determinism, registry
# --------------------------------------------------------------------------------------------

ALL_SENSORS = [BearingSensor(), RangeSensor(), BeaconSensor()]


@pytest.mark.parametrize("sensor", ALL_SENSORS, ids=lambda s: s.name)
def test_broadcasting_shapes_and_values(sensor):
    rng = np.random.default_rng(1)
    q, c, n = 5, 3, 7
    low, high = sensor.domain.low[0], sensor.domain.high[0]
    z = rng.uniform(low, high, size=(q, 1, 1))
    poses = rng.uniform(-20, 20, size=(1, c, 2))
    particles = np.column_stack(
        [rng.uniform(-20, 20, size=(n, 2)), rng.uniform(0, 2 * np.pi, size=(n, 1))]
    )[:, : sensor.target_dim]
    logp = sensor.log_likelihood(z, poses, particles)
    assert logp.shape == (q, c, n)
    for i in range(q):
        for j in range(c):
            one = sensor.log_likelihood(z[i, 0], poses[0, j], particles)
            assert one.shape == (n,)
            np.testing.assert_allclose(logp[i, j], one, rtol=1e-13)
    edges = np.linspace(low, high, 9)
    bins = sensor.bin_probabilities(edges, poses, particles)
    assert bins.shape == (1, c, n, 8)
    samples = sensor.sample(poses[0], particles[:c], rng)
    assert samples.shape == (c, 1)
    samples = sensor.sample(poses, particles[:1], rng)  # (1, C, 2) with (1, d)
    assert samples.shape == (1, c, 1)


@pytest.mark.parametrize(
    ("factory", "message"),
    [
        (lambda: BearingSensor(0.0), "sigma"),
        (lambda: BearingSensor(float("nan")), "sigma"),
        (lambda: BearingSensor(-1.0), "sigma"),
        (lambda: RangeSensor(sigma=float("inf")), "sigma"),
        (lambda: RangeSensor(max_range=0.0), "max_range"),
        (lambda: BeaconSensor(moment=-3.0), "moment"),
        (lambda: BeaconSensor(noise_std=0.0), "noise_std"),
    ],
)
def test_bad_parameters_raise_value_error(factory, message):
    with pytest.raises(ValueError, match=message):
        factory()


def test_non_numeric_parameter_raises_type_error():
    with pytest.raises(TypeError, match="sigma"):
        BearingSensor("0.1")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="moment"):
        BeaconSensor(moment=None)  # type: ignore[arg-type]


@pytest.mark.parametrize("sensor", ALL_SENSORS, ids=lambda s: s.name)
def test_bad_arrays_name_the_argument(sensor):
    d = sensor.target_dim
    particles = np.zeros((4, d))
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"poses.*\(\.\.\., 2\)"):
        sensor.log_likelihood(np.zeros((3, 1)), np.zeros((3, 3)), particles)
    with pytest.raises(ValueError, match=r"z.*\(\.\.\., 1\)"):
        sensor.log_likelihood(np.zeros((3, 2)), np.zeros((3, 2)), particles)
    with pytest.raises(ValueError, match="particles"):
        sensor.log_likelihood(np.zeros((3, 1)), np.zeros((3, 2)), np.zeros(d))
    with pytest.raises(ValueError, match="particles"):
        sensor.log_likelihood(np.zeros((3, 1)), np.zeros((3, 2)), np.zeros((4, 1)))
    with pytest.raises(ValueError, match="z"):
        sensor.log_likelihood(np.full((3, 1), np.nan), np.zeros((3, 2)), particles)
    with pytest.raises(ValueError, match="do not broadcast"):
        sensor.log_likelihood(np.zeros((3, 1)), np.zeros((4, 2)), particles)
    with pytest.raises(ValueError, match="targets"):
        sensor.sample(np.zeros((3, 2)), np.zeros((3, 1)), rng)
    with pytest.raises(TypeError, match="rng"):
        sensor.sample(np.zeros((3, 2)), np.zeros((3, d)), 42)
    with pytest.raises(ValueError, match="edges"):
        sensor.bin_probabilities(np.array([1.0, 0.5]), np.zeros(2), particles)
    with pytest.raises(ValueError, match="edges"):
        sensor.bin_probabilities(np.zeros((2, 2)), np.zeros(2), particles)


def test_periodic_edges_must_lie_in_domain():
    with pytest.raises(ValueError, match="edges"):
        BearingSensor().bin_probabilities(np.array([0.0, 4.0]), np.zeros(2), np.ones((1, 2)))
    with pytest.raises(ValueError, match="edges"):
        BeaconSensor().bin_probabilities(np.array([-0.5, 1.0]), np.zeros(2), np.ones((1, 3)))


@pytest.mark.parametrize("sensor", ALL_SENSORS, ids=lambda s: s.name)
def test_sampling_is_deterministic_under_seed(sensor):
    poses = np.random.default_rng(2).uniform(-10, 10, size=(20, 2))
    target = np.array([1.0, 2.0, 0.5])[: sensor.target_dim]
    first = sensor.sample(poses, target, np.random.default_rng(99))
    second = sensor.sample(poses, target, np.random.default_rng(99))
    third = sensor.sample(poses, target, np.random.default_rng(100))
    np.testing.assert_array_equal(first, second)
    assert not np.array_equal(first, third)


def test_registry_and_make_sensor():
    assert set(SENSOR_REGISTRY) == {"bearing", "beacon", "range"}
    for name, cls in SENSOR_REGISTRY.items():
        sensor = make_sensor(name)
        assert isinstance(sensor, cls) and isinstance(sensor, Sensor)
        assert sensor.name == name and sensor.pose_dim == 2 and sensor.obs_dim == 1
        assert isinstance(sensor.domain, ObservationDomain)
    assert make_sensor("bearing", sigma=0.3).sigma == 0.3
    instance = RangeSensor()
    assert make_sensor(instance) is instance
    with pytest.raises(TypeError, match="keyword"):
        make_sensor(instance, sigma=1.0)
    with pytest.raises(ValueError, match="bearing"):
        make_sensor("sonar")
    with pytest.raises(TypeError, match="spec"):
        make_sensor(3.0)  # type: ignore[arg-type]
    assert BeaconSensor().domain.high == (math.pi,) and BeaconSensor().target_dim == 3
    assert RangeSensor(0.5, 60.0).domain.low == (-3.0,)
    assert RangeSensor(0.5, 60.0).domain.high == (63.0,)
