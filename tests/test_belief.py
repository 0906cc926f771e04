"""Tests for infoseek.envs.belief and infoseek.envs.targets.

The particle posterior is checked against brute-force grid Bayes posteriors computed
independently here; estimates against closed forms; degeneracy recovery, determinism and
input validation directly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import infoseek.envs
from infoseek.envs.belief import (
    DEFAULT_TEMPERING_ESS,
    BeliefUpdate,
    BeliefView,
    ParticleBelief,
    check_belief_settings,
)
from infoseek.envs.sensors import BeaconSensor, BearingSensor
from infoseek.envs.sensors.base import ObservationDomain, Sensor
from infoseek.envs.targets import (
    TARGET_MOTION_REGISTRY,
    RandomWalkTarget,
    StationaryTarget,
    TargetSpace,
    make_target_motion,
)

PLANAR = TargetSpace.planar()
ORIENTED = TargetSpace.planar_with_orientation()


class GaussianPositionSensor:
    """Test sensor: ``z = target position + N(0, s^2 I)`` (independent of the pose)."""

    name = "gaussian_position"
    pose_dim = 2
    target_dim = 2
    obs_dim = 2

    def __init__(self, s: float = 2.0) -> None:
        self.s = s
        self.domain = ObservationDomain((-100.0, -100.0), (140.0, 140.0), (False, False))

    def sample(self, poses, targets, rng):
        t = np.broadcast_to(
            np.asarray(targets)[..., :2],
            np.broadcast_shapes(np.shape(poses), np.shape(targets)[:-1] + (2,)),
        )
        return t + self.s * rng.standard_normal(t.shape)

    def log_likelihood(self, z, poses, particles):
        z = np.asarray(z)[..., None, :]
        d2 = np.sum((z - particles[:, :2]) ** 2, axis=-1)
        return -0.5 * d2 / self.s**2 - np.log(2 * np.pi * self.s**2)


class BearingLikeSensor:
    """Test sensor: bearing from the pose, wrapped into [-pi, pi), Gaussian residual."""

    name = "bearing_like"
    pose_dim = 2
    target_dim = 2
    obs_dim = 1

    def __init__(self, sigma: float = 0.2) -> None:
        self.sigma = sigma
        self.domain = ObservationDomain((-np.pi,), (np.pi,), (True,))

    def sample(self, poses, targets, rng):
        d = np.asarray(targets)[..., :2] - poses
        b = np.arctan2(d[..., 1], d[..., 0]) + self.sigma * rng.standard_normal(d.shape[:-1])
        return (np.mod(b + np.pi, 2 * np.pi) - np.pi)[..., None]

    def log_likelihood(self, z, poses, particles):
        d = particles[:, :2] - np.asarray(poses)[..., None, :]
        b = np.arctan2(d[..., 1], d[..., 0])
        r = np.mod(np.asarray(z)[..., 0:1] - b + np.pi, 2 * np.pi) - np.pi
        return -0.5 * (r / self.sigma) ** 2 - np.log(np.sqrt(2 * np.pi) * self.sigma)


def grid_points(n: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres of an n x n grid over the 40 x 40 box, and their coordinates."""
    c = (np.arange(n) + 0.5) * 40.0 / n
    gx, gy = np.meshgrid(c, c, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1), c


def test_sensor_doubles_satisfy_protocol() -> None:
    assert isinstance(GaussianPositionSensor(), Sensor)
    assert isinstance(BearingLikeSensor(), Sensor)


# --------------------------------------------------------------------------- grid Bayes
def test_weights_match_grid_bayes_posterior() -> None:
    """Particles on grid points with a non-uniform prior: weights == exact grid posterior."""
    pts, _ = grid_points(30)
    rng = np.random.default_rng(0)
    prior = rng.dirichlet(np.ones(len(pts)))
    belief = ParticleBelief(pts, PLANAR, rng, log_weights=np.log(prior), resample_threshold=0.0)
    bearing = BearingLikeSensor(0.25)
    gauss = GaussianPositionSensor(4.0)
    poses = np.array([[0.0, 0.0], [40.0, 0.0], [20.0, 45.0]])
    z_b = np.array([[0.9], [2.3], [-1.6]])
    z_g = np.array([[18.0, 22.0]])

    # independent brute force: product of scipy densities
    post = prior.copy()
    for pose, zb in zip(poses, z_b[:, 0], strict=True):
        true_b = np.arctan2(pts[:, 1] - pose[1], pts[:, 0] - pose[0])
        resid = np.angle(np.exp(1j * (zb - true_b)))
        post *= stats.norm.pdf(resid, scale=0.25)
    evidence_b = post.sum()
    post_b = post / evidence_b
    gauss_lik = stats.multivariate_normal(mean=z_g[0], cov=16.0 * np.eye(2)).pdf(pts)
    post_bg = post_b * gauss_lik
    evidence_g = post_bg.sum()
    post_bg /= evidence_g

    upd = belief.update(bearing, z_b, poses)
    assert upd == BeliefUpdate(False, pytest.approx(np.log(evidence_b)), 3)
    np.testing.assert_allclose(belief.weights, post_b, rtol=1e-9, atol=1e-300)
    upd = belief.update(gauss, z_g, np.zeros((1, 2)))
    assert upd.log_evidence == pytest.approx(np.log(evidence_g))
    np.testing.assert_allclose(belief.weights, post_bg, rtol=1e-9, atol=1e-300)
    np.testing.assert_allclose(belief.mmse(), post_bg @ pts, rtol=1e-9)
    assert np.exp(belief.log_weights).sum() == pytest.approx(1.0)


def test_bearing_sensor_of_the_project_matches_grid_posterior() -> None:
    sensors = pytest.importorskip("infoseek.envs.sensors")
    if not hasattr(sensors, "BearingSensor"):
        pytest.skip("BearingSensor not available yet")
    sensor = sensors.BearingSensor(sigma=0.2)
    pts, _ = grid_points(30)
    belief = ParticleBelief(pts, PLANAR, np.random.default_rng(0), resample_threshold=0.0)
    poses = np.array([[0.0, 0.0], [40.0, 5.0]])
    z = np.array([[0.8], [2.5]])
    belief.update(sensor, z, poses)
    post = np.ones(len(pts))
    for pose, zb in zip(poses, z[:, 0], strict=True):
        true_b = np.arctan2(pts[:, 1] - pose[1], pts[:, 0] - pose[0])
        resid = np.angle(np.exp(1j * (zb - true_b)))
        # wrapped normal: sum over a few windings (sigma = 0.2 makes this exact to 1e-12)
        post *= sum(stats.norm.pdf(resid + 2 * np.pi * k, scale=0.2) for k in (-1, 0, 1))
    post /= post.sum()
    np.testing.assert_allclose(belief.weights, post, rtol=1e-6, atol=1e-12)


def test_random_particles_agree_with_grid_posterior_within_mc_error() -> None:
    """Sampled prior + several updates (with resampling): MMSE and mass_within vs grid."""
    sensor = GaussianPositionSensor(3.0)
    bearing = BearingLikeSensor(0.3)
    poses = np.array([[0.0, 0.0], [40.0, 40.0]])
    z_g = np.array([[25.0, 12.0], [23.0, 14.0]])
    z_b = np.array([[0.5], [-2.3]])

    fine, c = grid_points(400)
    logp = sensor.log_likelihood(z_g, poses, fine).sum(0)
    logp += bearing.log_likelihood(z_b, poses, fine).sum(0)
    grid_post = np.exp(logp - logp.max())
    grid_post /= grid_post.sum()
    grid_mean = grid_post @ fine
    grid_sd = np.sqrt(grid_post @ (fine - grid_mean) ** 2)
    center = np.array([24.0, 13.0])
    grid_mass = grid_post[np.linalg.norm(fine - center, axis=1) <= 2.0].sum()

    # importance sampling from the prior (no resampling, so the ESS is the honest sample size)
    belief = ParticleBelief.from_prior(PLANAR, 200_000, np.random.default_rng(5))
    belief.update(sensor, z_g[:1], poses[:1])
    belief.update(bearing, z_b, poses)
    belief.update(sensor, z_g[1:], poses[1:])
    ess = belief.ess
    assert ess > 1000
    tol = 5 * grid_sd / np.sqrt(ess)
    assert np.all(np.abs(belief.mmse() - grid_mean) < tol)
    mass = belief.mass_within(2.0, center)
    assert abs(mass - grid_mass) < 5 * np.sqrt(grid_mass * (1 - grid_mass) / ess)


def test_closed_loop_bearings_localises_stationary_target() -> None:
    rng = np.random.default_rng(11)
    sensor = BearingLikeSensor(0.1)
    truth = np.array([27.0, 13.0])
    poses = np.array([[0.0, 0.0], [40.0, 0.0], [0.0, 40.0], [40.0, 40.0]])
    belief = ParticleBelief.from_prior(PLANAR, 2000, rng)
    h0 = belief.entropy()
    for _ in range(10):
        belief.predict()
        belief.update(sensor, sensor.sample(poses, truth, rng), poses)
        belief.resample_if_needed()
    assert np.linalg.norm(belief.mmse() - truth) < 1.0
    assert belief.mass_within(1.0) > 0.5
    assert belief.entropy() < h0 - 4.0


# --------------------------------------------------------------------------- degeneracy
def test_impossible_observation_is_dropped_without_nan() -> None:
    belief = ParticleBelief.from_prior(PLANAR, 500, np.random.default_rng(1))
    before = belief.view()
    sensor = GaussianPositionSensor(0.1)
    upd = belief.update(sensor, np.array([[1000.0, 1000.0]]), np.zeros((1, 2)))
    assert upd.recovered and upd.n_observations == 0
    assert not np.isnan(upd.log_evidence)
    assert np.all(np.isfinite(belief.log_weights)) and np.all(np.isfinite(belief.weights))
    np.testing.assert_array_equal(belief.weights, before.weights)
    np.testing.assert_array_equal(belief.particles, before.particles)
    # still usable afterwards
    upd = belief.update(GaussianPositionSensor(2.0), np.array([[10.0, 30.0]]), np.zeros((1, 2)))
    assert not upd.recovered
    belief.resample_if_needed()
    assert np.linalg.norm(belief.mmse() - [10.0, 30.0]) < 2.0
    assert np.isfinite(belief.entropy())


def test_recovery_reseeds_from_prior() -> None:
    rng = np.random.default_rng(2)
    particles = rng.uniform(0.0, 1.0, (1000, 2))  # everything in a corner
    # a genuine outlier is still recovered from when tempering is on (the tempered evidence of
    # the corner particles stays far below -700)
    tempered = ParticleBelief(particles, PLANAR, np.random.default_rng(2), recovery_fraction=0.5)
    sensor = GaussianPositionSensor(0.7)
    z = np.array([[30.0, 30.0]])
    upd = tempered.update(sensor, z, np.zeros((1, 2)))
    assert upd.recovered and upd.n_observations == 1 and upd.log_evidence < -700
    assert np.linalg.norm(tempered.mmse() - z[0]) < 1.5
    # without tempering the recovered set keeps the survivors unmoved
    belief = ParticleBelief(particles, PLANAR, rng, recovery_fraction=0.5, tempering_ess=0.0)
    upd = belief.update(sensor, z, np.zeros((1, 2)))
    assert upd.recovered and upd.n_observations == 1
    assert upd.log_evidence < -700
    assert np.all(np.isfinite(belief.weights)) and belief.weights.sum() == pytest.approx(1.0)
    assert np.linalg.norm(belief.mmse() - z[0]) < 1.5
    # exactly half the particles are fresh prior draws, the rest came from the corner
    in_corner = np.all(belief.particles <= 1.0, axis=1)
    assert in_corner.sum() >= 500


def test_all_minus_inf_likelihood_never_nan() -> None:
    class Impossible(GaussianPositionSensor):
        def log_likelihood(self, z, poses, particles):
            return np.full((len(z), len(particles)), -np.inf)

    belief = ParticleBelief.from_prior(PLANAR, 100, np.random.default_rng(3))
    upd = belief.update(Impossible(), np.zeros((2, 2)), np.zeros((2, 2)))
    assert upd.recovered and upd.log_evidence == -np.inf
    assert not np.any(np.isnan(belief.weights))
    assert belief.ess == pytest.approx(100.0)


# --------------------------------------------------------------------------- determinism
def _run(seed: int) -> ParticleBelief:
    rng = np.random.default_rng(seed)
    belief = ParticleBelief.from_prior(
        ORIENTED, 300, rng, motion=RandomWalkTarget(0.2, 0.05), resample_threshold=0.5
    )
    sensor = GaussianPositionSensor(3.0)
    obs_rng = np.random.default_rng(seed + 1000)
    for _ in range(6):
        belief.predict(0.5)
        z = np.array([20.0, 20.0]) + 3.0 * obs_rng.standard_normal((2, 2))
        belief.update(sensor, z, np.zeros((2, 2)))
        belief.resample_if_needed()
    return belief


def test_same_seed_same_belief() -> None:
    a, b, c = _run(7), _run(7), _run(8)
    np.testing.assert_array_equal(a.particles, b.particles)
    np.testing.assert_array_equal(a.log_weights, b.log_weights)
    assert not np.array_equal(a.particles, c.particles)


def test_copy_is_independent_and_replays_stream() -> None:
    belief = _run(3)
    twin = belief.copy()
    other = belief.copy(rng=np.random.default_rng(99))
    for b in (belief, twin, other):
        b.update(GaussianPositionSensor(1.0), np.array([[20.0, 20.0]]), np.zeros((1, 2)))
    for b in (belief, twin, other):
        b.predict(1.0)  # random-walk noise comes from the belief's generator
    np.testing.assert_array_equal(belief.particles, twin.particles)
    assert len(np.unique(belief.particles[:, 0])) > 10
    assert not np.array_equal(belief.particles, other.particles)


# --------------------------------------------------------------------------- resampling
def test_resampling_uniformises_weights_and_roughens() -> None:
    n = 10000
    particles = np.repeat(np.array([[10.0, 10.0], [20.0, 20.0]]), n // 2, axis=0)
    w = np.where(np.arange(n) < n // 2, 1.0, 3.0)
    rng = np.random.default_rng(4)
    belief = ParticleBelief(particles, PLANAR, rng, log_weights=np.log(w), roughening=0.1)
    assert belief.resample_if_needed()
    assert belief.ess == pytest.approx(n)
    assert not belief.resample_if_needed()  # uniform weights are left alone
    p = belief.particles
    near_first = np.linalg.norm(p - 10.0, axis=1) < 1.0
    assert near_first.mean() == pytest.approx(0.25, abs=1e-3)  # systematic: exact up to 1/N
    # jitter std = K * spread * N^(-1/d) = 0.1 * 10 * 10000^(-1/2) = 0.01
    dev = np.concatenate([p[near_first] - 10.0, p[~near_first] - 20.0]).ravel()
    assert np.std(dev) == pytest.approx(0.01, rel=0.05)
    assert len(np.unique(p[:, 0])) == n

    no_rough = ParticleBelief(particles, PLANAR, rng, log_weights=np.log(w), roughening=0.0)
    no_rough.resample_if_needed()
    assert len(np.unique(no_rough.particles[:, 0])) == 2


def test_roughening_keeps_particles_in_domain_and_angles_wrapped() -> None:
    rng = np.random.default_rng(5)
    n = 2000
    particles = np.column_stack(
        [np.full(n, 0.01), np.full(n, 39.99), np.where(np.arange(n) % 2, 0.01, 2 * np.pi - 0.01)]
    )
    particles[:5, :2] = [[0.0, 0.0], [40.0, 40.0], [0, 40], [40, 0], [20, 20]]
    w = rng.random(n)
    belief = ParticleBelief(particles, ORIENTED, rng, log_weights=np.log(w), roughening=0.5)
    belief.resample_if_needed()
    assert np.all(ORIENTED.contains(belief.particles))
    psi = belief.particles[:, 2]
    assert np.all((psi >= 0) & (psi < 2 * np.pi))
    # angle spread is measured around the circular mean (0.02), not across the wrap (2 pi)
    resid = np.angle(np.exp(1j * psi))
    assert np.max(np.abs(resid)) < 0.2


def test_collapsed_particle_set_is_spread_again() -> None:
    """All particles identical: the spread floor still separates them after resampling."""
    belief = ParticleBelief(
        np.full((1000, 2), 17.0), PLANAR, np.random.default_rng(0), log_weights=np.arange(1000.0)
    )
    assert belief.resample_if_needed()
    assert len(np.unique(belief.particles[:, 0])) == 1000
    assert np.all(np.abs(belief.particles - 17.0) < 0.01)


def test_threshold_zero_never_resamples() -> None:
    belief = ParticleBelief.from_prior(
        PLANAR, 200, np.random.default_rng(0), resample_threshold=0.0
    )
    belief.update(GaussianPositionSensor(1.0), np.array([[5.0, 5.0]]), np.zeros((1, 2)))
    assert belief.ess < 50
    assert not belief.resample_if_needed()


# --------------------------------------------------------------------------- estimates
def test_entropy_of_uniform_belief_is_log_area() -> None:
    pts, _ = grid_points(80)
    belief = ParticleBelief(pts, PLANAR, np.random.default_rng(0), entropy_bins=(40, 40))
    assert belief.entropy() == pytest.approx(np.log(1600.0), abs=1e-9)
    # the adaptive default: the lattice's box is 39.5 x 39.5 and Miller-Madow adds 0.06
    lattice = ParticleBelief(pts, PLANAR, np.random.default_rng(0))
    assert lattice.entropy() == pytest.approx(np.log(1600.0), rel=0.005)
    big = ParticleBelief.from_prior(PLANAR, 400_000, np.random.default_rng(1))
    assert big.entropy() == pytest.approx(np.log(1600.0), abs=0.01)
    oriented = ParticleBelief.from_prior(ORIENTED, 400_000, np.random.default_rng(2))
    assert oriented.entropy() == pytest.approx(np.log(1600.0 * 2 * np.pi), abs=0.05)
    # all mass in one cell of a fixed grid: H = log(cell volume) = log(1)
    point = ParticleBelief(
        np.full((10, 2), 3.3), PLANAR, np.random.default_rng(0), entropy_bins=(40, 40)
    )
    assert point.entropy() == pytest.approx(0.0, abs=1e-12)
    # half the box: log(800); custom grid
    left = pts[pts[:, 0] < 20]
    half = ParticleBelief(left, PLANAR, np.random.default_rng(0), entropy_bins=(4, 4))
    assert half.entropy() == pytest.approx(np.log(800.0), abs=1e-9)


def test_circular_mean_across_wrap() -> None:
    psi = np.array([2 * np.pi - 0.1, 0.1, 2 * np.pi - 0.3, 0.3])
    particles = np.column_stack([np.full(4, 5.0), np.full(4, 6.0), psi])
    space = TargetSpace(
        low=(0.0, 0.0, 0.0),
        high=(40.0, 40.0, 2 * np.pi),
        periodic=(False, False, True),
        axial=(False, False, False),
        names=("x", "y", "heading"),
    )
    est = ParticleBelief(particles, space, np.random.default_rng(0)).mmse()
    np.testing.assert_allclose(est[:2], [5.0, 6.0])
    assert np.angle(np.exp(1j * est[2])) == pytest.approx(0.0, abs=1e-12)
    # weighted: mass 3:1 on +0.2 / -0.2 -> atan2(0.5 sin 0.2, cos 0.2)
    w = np.log([1.0, 3.0])
    p2 = np.array([[1.0, 1.0, 2 * np.pi - 0.2], [1.0, 1.0, 0.2]])
    est2 = ParticleBelief(p2, space, np.random.default_rng(0), log_weights=w).mmse()
    assert est2[2] == pytest.approx(np.arctan2(0.5 * np.sin(0.2), np.cos(0.2)))


def test_axial_mean_across_wrap() -> None:
    # pi - 0.1 and 0.1 are axes 0.2 apart across the axial wrap point (period pi)
    psi = np.array([np.pi - 0.1, 0.1, 2 * np.pi - 0.1, np.pi + 0.1])
    particles = np.column_stack([np.full(4, 5.0), np.full(4, 6.0), psi])
    est = ParticleBelief(particles, ORIENTED, np.random.default_rng(0)).mmse()
    axial_err = np.angle(np.exp(2j * est[2])) / 2
    assert axial_err == pytest.approx(0.0, abs=1e-12)
    assert 0.0 <= est[2] < np.pi
    # psi and psi + pi are the same axis
    p2 = np.column_stack([np.ones(2), np.ones(2), [0.7, 0.7 + np.pi]])
    assert ParticleBelief(p2, ORIENTED, np.random.default_rng(0)).mmse()[2] == pytest.approx(0.7)


def test_mass_within_and_mass_grid() -> None:
    particles = np.array([[10.0, 10.0], [10.5, 10.0], [30.0, 30.0], [35.0, 5.0]])
    w = np.array([0.4, 0.3, 0.2, 0.1])
    belief = ParticleBelief(particles, PLANAR, np.random.default_rng(0), log_weights=np.log(w))
    assert belief.mass_within(1.0, np.array([10.0, 10.0])) == pytest.approx(0.7)
    assert belief.mass_within(0.4, np.array([10.0, 10.0])) == pytest.approx(0.4)
    assert belief.mass_within(0.0, np.array([30.0, 30.0, 0.0][:2])) == pytest.approx(0.2)
    assert belief.mass_within(100.0) == pytest.approx(1.0)
    mmse = w @ particles
    inside = np.linalg.norm(particles - mmse, axis=1) <= 8.0
    assert belief.mass_within(8.0) == pytest.approx(w[inside].sum())
    grid = belief.mass_grid((4, 8))
    assert grid.shape == (4, 8) and grid.sum() == pytest.approx(1.0)
    assert grid[1, 2] == pytest.approx(0.7)  # x in [10, 20), y in [10, 15)
    assert grid[3, 6] == pytest.approx(0.2)
    assert grid[3, 1] == pytest.approx(0.1)
    oriented = ParticleBelief(np.array([[1.0, 2.0, 3.0]]), ORIENTED, np.random.default_rng(0))
    assert oriented.mass_within(0.5, np.array([1.0, 2.0, 0.0])) == pytest.approx(1.0)


def test_read_only_views_are_stable_snapshots() -> None:
    belief = ParticleBelief.from_prior(PLANAR, 100, np.random.default_rng(0))
    view = belief.view()
    assert isinstance(view, BeliefView) and view.space is PLANAR
    for arr in (belief.particles, belief.weights, belief.log_weights, view.particles):
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[0] = 1.0
    snapshot = view.weights.copy()
    belief.update(GaussianPositionSensor(1.0), np.array([[5.0, 5.0]]), np.zeros((1, 2)))
    belief.resample_if_needed()
    np.testing.assert_array_equal(view.weights, snapshot)
    assert belief.n_particles == 100 and belief.dim == 2


def test_a_batch_update_of_plain_tempered_and_impossible_rows_equals_each_row_alone() -> None:
    """One batch update where one belief takes the plain Bayes step, two are tempered (one of
    them recovered from the prior) and one drops an impossible reading: every row equals the
    same belief updated alone, bit for bit, and arrays handed out before the update keep
    their values (the batch writes all its changed rows into new arrays at once)."""
    from infoseek.envs.belief_batch import BeliefBatch

    rng = np.random.default_rng(5)
    fix = np.array([20.0, 20.0])
    particles = np.stack(
        [
            fix + rng.uniform(-3.0, 3.0, (400, 2)),  # a 4-unit fix is mild: plain step
            fix + rng.uniform(-1.0, 1.0, (400, 2)),  # sharp relative to the set: tempered
            rng.uniform(0.0, 1.0, (400, 2)),  # all in a corner, far from the fix: recovered
            rng.uniform(0.0, 40.0, (400, 2)),  # a reading no particle can explain: dropped
        ]
    )
    readings = np.array([[[20.3, 19.8]], [[20.1, 20.2]], [[30.0, 30.0]], [[1e3, 1e3]]])
    sensors = [GaussianPositionSensor(s) for s in (4.0, 1e-3, 0.7, 1e-3)]
    settings = check_belief_settings(
        motion=None,
        resample_threshold=0.5,
        roughening=0.2,
        entropy_bins=None,
        recovery_fraction=0.5,
        tempering_ess=None,
        max_tempering_stages=20,
        space=PLANAR,
    )
    log_weights = np.full((4, 400), -math.log(400))
    streams = [np.random.default_rng(100 + k) for k in range(4)]

    class PerRowSensor(GaussianPositionSensor):  # belief k reads with sensors[k]
        def log_likelihood(self, z, poses, particles):
            return sensors[int(poses[0, 0])].log_likelihood(z, poses, particles)

    poses = np.zeros((4, 1, 2))
    poses[:, 0, 0] = np.arange(4)
    batch = BeliefBatch(
        particles.copy(),
        log_weights.copy(),
        PLANAR,
        [np.random.default_rng(100 + k) for k in range(4)],
        **settings,
    )
    handed_out = (batch.particles, batch.log_weights, batch.weights)
    snapshots = [a.copy() for a in handed_out]
    upd = batch.update(PerRowSensor(), readings, poses, np.ones((4, 1), dtype=bool))
    assert list(upd.n_stages > 1) == [False, True, True, False]
    assert list(upd.recovered) == [False, False, True, True]
    assert list(upd.n_observations) == [1, 1, 1, 0]
    for array, snapshot in zip(handed_out, snapshots, strict=True):
        np.testing.assert_array_equal(array, snapshot)
    for k in range(4):
        alone = BeliefBatch(
            particles[k : k + 1].copy(),
            log_weights[k : k + 1].copy(),
            PLANAR,
            [streams[k]],
            **settings,
        )
        one = alone.update(
            PerRowSensor(), readings[k : k + 1], poses[k : k + 1], np.ones((1, 1), dtype=bool)
        )
        assert one.n_stages[0] == upd.n_stages[k] and one.log_evidence[0] == upd.log_evidence[k]
        np.testing.assert_array_equal(alone.particles[0], batch.particles[k])
        np.testing.assert_array_equal(alone.log_weights[0], batch.log_weights[k])
        np.testing.assert_array_equal(alone.weights[0], batch.weights[k])
        expected = np.exp(batch.log_weights[k])
        np.testing.assert_array_equal(batch.weights[k], expected / expected.sum())
    np.testing.assert_array_equal(batch.particles[3], particles[3])  # the dropped reading


def test_empty_update_is_noop() -> None:
    belief = ParticleBelief.from_prior(PLANAR, 10, np.random.default_rng(0))
    upd = belief.update(GaussianPositionSensor(), np.zeros((0, 2)), np.zeros((0, 2)))
    assert upd == BeliefUpdate(False, 0.0, 0)


# --------------------------------------------------------------------------- targets
def test_target_space_basics() -> None:
    assert PLANAR.dim == 2 and PLANAR.position_dims == (0, 1)
    assert ORIENTED.axial == (False, False, True) and ORIENTED.periodic[2]
    s = ORIENTED.sample_uniform(5000, np.random.default_rng(0))
    assert s.shape == (5000, 3) and np.all(ORIENTED.contains(s))
    assert stats.kstest(s[:, 2] / (2 * np.pi), "uniform").pvalue > 1e-4
    wrapped = ORIENTED.wrap(np.array([[1.0, 2.0, -0.5], [1.0, 2.0, 2 * np.pi], [1, 2, -1e-18]]))
    np.testing.assert_allclose(wrapped[:, 2], [2 * np.pi - 0.5, 0.0, 0.0])
    assert np.all(wrapped[:, 2] < 2 * np.pi)
    assert ORIENTED.contains(np.array([[41.0, 1.0, 0.0]])).tolist() == [False]
    assert ORIENTED.contains(np.array([[40.0, 0.0, 9.0]])).tolist() == [True]
    assert TargetSpace.planar((10.0, 20.0)).volume == pytest.approx(200.0)


def test_target_space_validation() -> None:
    with pytest.raises(ValueError, match="length"):
        TargetSpace((0.0, 0.0), (1.0,), (False, False), (False, False), ("x", "y"))
    with pytest.raises(ValueError, match="low < high"):
        TargetSpace((0.0, 0.0), (1.0, 0.0), (False, False), (False, False), ("x", "y"))
    with pytest.raises(ValueError, match="axial"):
        TargetSpace((0, 0, 0), (1, 1, 1), (False, False, False), (False, False, True), tuple("xyz"))
    with pytest.raises(ValueError, match="position"):
        TargetSpace((0.0, 0.0), (1.0, 1.0), (True, False), (False, False), ("x", "y"))
    with pytest.raises(ValueError, match="size"):
        TargetSpace.planar((0.0, 5.0))
    with pytest.raises(ValueError, match="n must"):
        PLANAR.sample_uniform(-1, np.random.default_rng(0))
    with pytest.raises(TypeError, match="rng"):
        PLANAR.sample_uniform(3, 0)  # type: ignore[arg-type]


def test_motion_models() -> None:
    rng = np.random.default_rng(0)
    states = ORIENTED.sample_uniform(20000, rng)
    same = StationaryTarget().propagate(states, ORIENTED, 1.0, rng)
    np.testing.assert_array_equal(same, states)
    assert same is not states
    walk = RandomWalkTarget(position_std=0.3, angle_std=0.1)
    interior = np.tile([20.0, 20.0, 3.0], (20000, 1))
    moved = walk.propagate(interior, ORIENTED, 4.0, rng)
    np.testing.assert_allclose(np.std(moved - interior, axis=0), [0.6, 0.6, 0.2], rtol=0.03)
    edge = walk.propagate(np.tile([0.0, 40.0, 0.0], (5000, 1)), ORIENTED, 1.0, rng)
    assert np.all(ORIENTED.contains(edge))
    assert np.all((edge[:, 2] >= 0) & (edge[:, 2] < 2 * np.pi))
    # reflection at x = 0 folds the Gaussian: mean |N(0, 0.3^2)| = 0.3 sqrt(2/pi)
    assert np.mean(edge[:, 0]) == pytest.approx(0.3 * np.sqrt(2 / np.pi), rel=0.05)
    assert set(TARGET_MOTION_REGISTRY) == {"stationary", "random_walk"}
    assert isinstance(make_target_motion("random_walk", position_std=0.2), RandomWalkTarget)
    assert make_target_motion(walk) is walk
    with pytest.raises(ValueError, match="random_walk"):
        make_target_motion("teleport")
    with pytest.raises(TypeError, match="keyword"):
        make_target_motion(walk, position_std=1.0)
    with pytest.raises(ValueError, match="position_std"):
        RandomWalkTarget(position_std=-1.0)
    with pytest.raises(ValueError, match="dt"):
        walk.propagate(interior, ORIENTED, 0.0, rng)


# --------------------------------------------------------------------------- validation
def test_bad_constructor_inputs() -> None:
    rng = np.random.default_rng(0)
    good = PLANAR.sample_uniform(10, rng)
    with pytest.raises(ValueError, match="particles"):
        ParticleBelief(np.zeros((10, 3)), PLANAR, rng)
    with pytest.raises(ValueError, match="particles"):
        ParticleBelief(np.full((10, 2), np.nan), PLANAR, rng)
    with pytest.raises(TypeError, match="space"):
        ParticleBelief(good, "planar", rng)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="rng"):
        ParticleBelief(good, PLANAR, 0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="log_weights"):
        ParticleBelief(good, PLANAR, rng, log_weights=np.zeros(9))
    with pytest.raises(ValueError, match="log_weights"):
        ParticleBelief(good, PLANAR, rng, log_weights=np.full(10, -np.inf))
    with pytest.raises(ValueError, match="log_weights"):
        ParticleBelief(good, PLANAR, rng, log_weights=np.full(10, np.nan))
    with pytest.raises(ValueError, match="resample_threshold"):
        ParticleBelief(good, PLANAR, rng, resample_threshold=1.5)
    with pytest.raises(ValueError, match="roughening"):
        ParticleBelief(good, PLANAR, rng, roughening=-0.1)
    with pytest.raises(ValueError, match="recovery_fraction"):
        ParticleBelief(good, PLANAR, rng, recovery_fraction=0.0)
    with pytest.raises(ValueError, match="entropy_bins"):
        ParticleBelief(good, PLANAR, rng, entropy_bins=(4,))
    with pytest.raises(TypeError, match="motion"):
        ParticleBelief(good, PLANAR, rng, motion="stationary")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="n_particles"):
        ParticleBelief.from_prior(PLANAR, 0, rng)


def test_bad_update_and_estimate_inputs() -> None:
    belief = ParticleBelief.from_prior(PLANAR, 10, np.random.default_rng(0))
    sensor = GaussianPositionSensor()
    with pytest.raises(ValueError, match="z must"):
        belief.update(sensor, np.zeros(2), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="z must"):
        belief.update(sensor, np.zeros((1, 3)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="poses"):
        belief.update(sensor, np.zeros((1, 2)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="rows M"):
        belief.update(sensor, np.zeros((2, 2)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="finite"):
        belief.update(sensor, np.full((1, 2), np.nan), np.zeros((1, 2)))
    with pytest.raises(TypeError, match="sensor"):
        belief.update(object(), np.zeros((1, 2)), np.zeros((1, 2)))

    class NanSensor(GaussianPositionSensor):
        def log_likelihood(self, z, poses, particles):
            return np.full((len(z), len(particles)), np.nan)

    with pytest.raises(ValueError, match="NaN"):
        belief.update(NanSensor(), np.zeros((1, 2)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="dt"):
        belief.predict(0.0)
    with pytest.raises(ValueError, match="radius"):
        belief.mass_within(-1.0)
    with pytest.raises(ValueError, match="center"):
        belief.mass_within(1.0, np.zeros(5))
    with pytest.raises(ValueError, match="shape"):
        belief.mass_grid((0, 3))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_one_nan_or_plus_inf_likelihood_is_refused_minus_inf_is_not(bad: float) -> None:
    class OneBadValue(GaussianPositionSensor):
        def log_likelihood(self, z, poses, particles):
            values = super().log_likelihood(z, poses, particles)
            values[0, 137] = bad  # one particle of one reading
            return values

    belief = ParticleBelief.from_prior(
        PLANAR, 500, np.random.default_rng(8), resample_threshold=0.0
    )
    if bad == -np.inf:  # an impossible particle: weight 0 (no resampling to move it)
        belief.update(OneBadValue(), np.full((1, 2), 20.0), np.zeros((1, 2)))
        assert belief.weights[137] == 0.0 and np.isclose(belief.weights.sum(), 1.0)
        return
    with pytest.raises(ValueError, match="gaussian_position.*NaN or \\+inf"):
        belief.update(OneBadValue(), np.full((1, 2), 20.0), np.zeros((1, 2)))


# --------------------------------------------------------------------------- tempering
def _sharp_case(seed: int, **kwargs) -> tuple[ParticleBelief, BeliefUpdate, np.ndarray]:
    """2000 particles spread +-1 around the truth; one Gaussian position fix of std 3e-4.

    The nearest of the particles is ~0.02 (about 70 std) away, so a one-shot update has log
    evidence far below -700.
    """
    rng = np.random.default_rng(seed)
    truth = np.array([20.0, 20.0])
    belief = ParticleBelief(truth + rng.uniform(-1.0, 1.0, (2000, 2)), PLANAR, rng, **kwargs)
    z = truth[None, :] + 1e-4
    upd = belief.update(GaussianPositionSensor(3e-4), z, np.zeros((1, 2)))
    return belief, upd, z[0]


@pytest.mark.parametrize("seed", range(1, 5))
def test_tempering_follows_a_sharp_consistent_observation(seed: int) -> None:
    plain, plain_upd, _ = _sharp_case(seed, tempering_ess=0.0)
    assert plain_upd.recovered and plain_upd.log_evidence < -700  # the failure being fixed
    belief, upd, z = _sharp_case(seed)
    assert not upd.recovered and upd.n_observations == 1 and upd.n_stages > 1
    # exact log evidence: the fix lies inside the uniform +-1 prior box -> log(1/4)
    assert abs(upd.log_evidence - np.log(0.25)) < 1.5
    assert np.all(np.isfinite(belief.log_weights)) and not np.any(np.isnan(belief.particles))
    belief.resample_if_needed()
    assert np.linalg.norm(belief.mmse() - z) < 3e-4
    assert belief.mass_within(1.5e-3, z) > 0.95  # 5 std
    spread = belief.particles.std(axis=0)
    assert np.all((spread > 1.5e-4) & (spread < 6e-4))  # posterior std 3e-4 (+ roughening)


def _grid_moments(logp: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and per-coordinate std of the posterior ``exp(logp)`` on the ``(G, 2)`` grid."""
    post = np.exp(logp - logp.max())
    post /= post.sum()
    mean = post @ grid
    return mean, np.sqrt(post @ (grid - mean) ** 2)


def test_tempered_posterior_agrees_with_grid_posterior() -> None:
    """Uniform prior on the box, sharp fix + bearing: tempered particles vs a fine grid."""
    gauss = GaussianPositionSensor(0.25)
    bearing = BearingLikeSensor(0.02)
    z_g = np.array([[12.3, 25.1]])
    pose = np.array([[0.0, 0.0]])
    z_b = np.array([[np.arctan2(25.0, 12.5)]])
    c = 11.0 + (np.arange(800) + 0.5) * 3.0 / 800
    d = 24.0 + (np.arange(800) + 0.5) * 3.0 / 800
    fine = np.stack(np.meshgrid(c, d, indexing="ij"), axis=-1).reshape(-1, 2)
    logp = gauss.log_likelihood(z_g, pose, fine)[0] + bearing.log_likelihood(z_b, pose, fine)[0]
    mean, sd = _grid_moments(logp, fine)

    means, sds = [], []
    for seed in range(4):
        belief = ParticleBelief.from_prior(PLANAR, 4000, np.random.default_rng(seed))
        upd = belief.update(gauss, z_g, pose)
        assert upd.n_stages > 1 and not upd.recovered
        upd = belief.update(bearing, z_b, pose)
        assert not upd.recovered
        belief.resample_if_needed()
        means.append(belief.mmse())
        sds.append(belief.particles.std(axis=0))
    # no noticeable bias: every run's mean within 0.15 posterior std, spread within 20 %
    assert np.all(np.abs(np.array(means) - mean) < 0.15 * sd), (means, mean, sd)
    np.testing.assert_allclose(np.mean(sds, axis=0), sd, rtol=0.2)


def test_tempering_after_earlier_observations_targets_the_exact_posterior() -> None:
    """Two 0.05 rad bearings from the west, then a 0.002 rad bearing from the south (tempered,
    on a concentrated prior): particles vs a fine grid of the exact posterior. A move that
    ignores the earlier bearings spreads the particles along the last one (std ~1.3 in y)."""
    truth = np.array([20.0, 20.0])
    west, south = BearingSensor(sigma=0.05), BearingSensor(sigma=0.002)
    poses_w, poses_s = np.array([[0.0, 20.0], [0.0, 22.0]]), np.array([[20.0, 0.0]])
    noise = np.random.default_rng(1).standard_normal(3)
    z_w = np.arctan2(truth[1] - poses_w[:, 1], truth[0] - poses_w[:, 0])[:, None]
    z_w += 0.05 * noise[:2, None]
    z_s = np.array([[np.pi / 2 + 0.002 * noise[2]]])
    cells = np.linspace(0.0, 40.0, 1601)
    grid = np.stack(np.meshgrid(cells, cells), axis=-1).reshape(-1, 2)
    logp = west.log_likelihood(z_w, poses_w, grid).sum(0) + south.log_likelihood(
        z_s, poses_s, grid
    ).sum(0)
    mean, sd = _grid_moments(logp, grid)

    means, sds = [], []
    for seed in range(5):
        belief = ParticleBelief.from_prior(PLANAR, 2000, np.random.default_rng(seed))
        belief.update(west, z_w, poses_w)
        belief.resample_if_needed()
        upd = belief.update(south, z_s, poses_s)
        assert upd.n_stages > 1 and not upd.recovered
        means.append(belief.weights @ belief.particles)
        sds.append(np.sqrt(belief.weights @ (belief.particles - belief.mmse()) ** 2))
    assert np.all(np.abs(np.array(means) - mean) < 0.25 * sd), (means, mean, sd)
    np.testing.assert_allclose(np.mean(sds, axis=0), sd, rtol=0.1)


def test_a_copy_keeps_the_observations_its_moves_target() -> None:
    """A copy tempers exactly like the original (it carries the kept observations)."""
    belief = ParticleBelief.from_prior(PLANAR, 1000, np.random.default_rng(2))
    belief.update(BearingSensor(sigma=0.05), np.array([[0.02]]), np.array([[0.0, 20.0]]))
    belief.resample_if_needed()
    twin = belief.copy()
    sharp, z, pose = BearingSensor(sigma=0.002), np.array([[1.57]]), np.array([[20.0, 0.0]])
    assert belief.update(sharp, z, pose).n_stages > 1
    twin.update(sharp, z, pose)
    np.testing.assert_array_equal(twin.particles, belief.particles)
    fresh = ParticleBelief(twin.particles, PLANAR, np.random.default_rng(2))
    assert fresh.copy().update(sharp, z, pose).n_stages >= 1  # no kept observations: fine


def test_tempering_needs_a_stationary_target() -> None:
    good = PLANAR.sample_uniform(10, np.random.default_rng(0))
    walk = RandomWalkTarget()
    with pytest.raises(ValueError, match="tempering_ess.*stationary"):
        ParticleBelief(good, PLANAR, np.random.default_rng(0), motion=walk, tempering_ess=0.1)
    sharp, z, pose = GaussianPositionSensor(0.05), np.array([[20.0, 20.0]]), np.zeros((1, 2))
    stages = {}
    for motion in (walk, None):  # default: tempering off for the moving target only
        many = PLANAR.sample_uniform(2000, np.random.default_rng(1))
        belief = ParticleBelief(many, PLANAR, np.random.default_rng(1), motion=motion)
        stages[motion is None] = belief.update(sharp, z, pose).n_stages
    assert stages == {False: 1, True: stages[True]} and stages[True] > 1
    env = infoseek.envs.bearings_v0.parallel_env(target_motion="random_walk")
    assert env.unwrapped.config.tempering_ess == 0.0
    assert infoseek.envs.bearings_v0.parallel_env().unwrapped.config.tempering_ess == 0.1
    with pytest.raises(ValueError, match="tempering_ess"):
        infoseek.envs.bearings_v0.parallel_env(target_motion="random_walk", tempering_ess=0.1)


def test_tempering_is_deterministic_under_a_seed() -> None:
    a, upd_a, _ = _sharp_case(3)
    b, upd_b, _ = _sharp_case(3)
    c, _, _ = _sharp_case(4)
    assert upd_a == upd_b
    np.testing.assert_array_equal(a.particles, b.particles)
    np.testing.assert_array_equal(a.log_weights, b.log_weights)
    assert not np.array_equal(a.particles, c.particles)


@pytest.mark.parametrize(
    "kwargs", [{"tempering_ess": 0.0}, {"resample_threshold": 0.0}, {"max_tempering_stages": 1}]
)
def test_disabled_tempering_is_the_plain_bayes_update(kwargs) -> None:
    rng = np.random.default_rng(6)
    particles = PLANAR.sample_uniform(3000, rng)
    belief = ParticleBelief(particles, PLANAR, rng, **kwargs)
    sensor = GaussianPositionSensor(0.5)
    z = np.array([[12.0, 30.0], [12.5, 29.0]])
    loglik = sensor.log_likelihood(z, np.zeros((2, 2)), particles).sum(0)
    expected = loglik - np.log(np.sum(np.exp(loglik - loglik.max()))) - loglik.max()
    upd = belief.update(sensor, z, np.zeros((2, 2)))
    assert upd.n_stages == 1 and not upd.recovered
    assert belief.ess < 0.1 * 3000  # tempering would have triggered
    np.testing.assert_array_equal(belief.particles, particles)
    np.testing.assert_allclose(belief.log_weights, expected, rtol=1e-12, atol=1e-9)
    assert upd.log_evidence == pytest.approx(np.log(np.mean(np.exp(loglik))), rel=1e-9)


def test_mild_update_takes_one_stage() -> None:
    belief = ParticleBelief.from_prior(PLANAR, 2000, np.random.default_rng(0))
    before = belief.particles.copy()
    upd = belief.update(GaussianPositionSensor(15.0), np.array([[20.0, 20.0]]), np.zeros((1, 2)))
    assert upd.n_stages == 1
    np.testing.assert_array_equal(belief.particles, before)


def test_bad_tempering_arguments() -> None:
    good = PLANAR.sample_uniform(10, np.random.default_rng(0))
    for bad in (-0.1, 1.0, np.nan, True):
        with pytest.raises(ValueError, match="tempering_ess"):
            ParticleBelief(good, PLANAR, np.random.default_rng(0), tempering_ess=bad)
    for bad in (0, 2.5, True):
        with pytest.raises(ValueError, match="max_tempering_stages"):
            ParticleBelief(good, PLANAR, np.random.default_rng(0), max_tempering_stages=bad)


def test_beacon_filter_noise_floor_is_an_inflated_noise_likelihood() -> None:
    """with_max_snr(c) evaluates the exact density with noise std max(s, |H| / c) per particle."""
    sensor = BeaconSensor(moment=1000.0, noise_std=1.0)
    rng = np.random.default_rng(3)
    particles = np.column_stack(
        [rng.uniform(0, 12, 40), rng.uniform(0, 12, 40), rng.uniform(0, 6, 40)]
    )
    pose, z = np.array([[5.0, 5.0]]), np.array([[0.7]])
    np.testing.assert_array_equal(
        sensor.with_max_snr(math.inf).log_likelihood(z, pose, particles),
        sensor.log_likelihood(z, pose, particles),
    )
    floored = sensor.with_max_snr(5.0).log_likelihood(z, pose, particles)[0]
    rho = np.linalg.norm(sensor.field(pose, particles), axis=-1)  # (N,) with noise_std 1
    assert np.any(rho > 5.0) and np.any(rho < 5.0)
    for k in range(len(particles)):
        inflated = BeaconSensor(moment=1000.0, noise_std=max(1.0, rho[k] / 5.0))
        expected = inflated.log_likelihood(z, pose, particles[k : k + 1])[0, 0]
        assert floored[k] == pytest.approx(expected, rel=1e-9, abs=1e-12)
    env = infoseek.envs.make("beacon_v0", n_agents=2, n_particles=100)
    assert env.unwrapped.config.filter_max_snr == 5.0
    with pytest.raises(ValueError, match="filter_max_snr"):
        infoseek.envs.make("bearings_v0", n_agents=2, filter_max_snr=5.0)


def _settings(**changes: object) -> dict:
    settings = {
        "motion": None,
        "resample_threshold": 1.0,
        "roughening": 0.2,
        "entropy_bins": None,
        "recovery_fraction": 0.5,
        "tempering_ess": None,
        "max_tempering_stages": 20,
        "space": PLANAR,
    }
    return check_belief_settings(**{**settings, **changes})


def test_belief_settings_are_plain_python_values_with_defaults_by_motion() -> None:
    settings = _settings(
        resample_threshold=np.float32(0.5),
        roughening=0,
        entropy_bins=(np.int64(4), 5),
        max_tempering_stages=np.int64(3),
    )
    assert isinstance(settings["motion"], StationaryTarget)
    assert settings["tempering_ess"] == DEFAULT_TEMPERING_ESS
    assert settings["entropy_bins"] == (4, 5) and all(
        type(b) is int for b in settings["entropy_bins"]
    )
    assert type(settings["max_tempering_stages"]) is int
    assert type(settings["resample_threshold"]) is float and type(settings["roughening"]) is float
    walk = RandomWalkTarget(0.5)
    moving = _settings(motion=walk)
    assert moving["motion"] is walk and moving["tempering_ess"] == 0.0
    assert _settings()["entropy_bins"] is None


@pytest.mark.parametrize(
    ("changes", "error", "named"),
    [
        ({"motion": "walk", "resample_threshold": 2.0}, TypeError, "motion"),
        ({"resample_threshold": 2.0, "roughening": -1.0}, ValueError, "resample_threshold"),
        ({"roughening": -1.0, "recovery_fraction": 0.0}, ValueError, "roughening"),
        ({"recovery_fraction": 0.0, "tempering_ess": 1.0}, ValueError, "recovery_fraction"),
        ({"tempering_ess": 1.0, "max_tempering_stages": 0}, ValueError, "tempering_ess"),
        ({"max_tempering_stages": 0, "entropy_bins": (4,)}, ValueError, "max_tempering_stages"),
        ({"entropy_bins": (4,)}, ValueError, "entropy_bins must be 2 positive integers"),
    ],
)
def test_belief_settings_report_the_first_bad_one(
    changes: dict, error: type[Exception], named: str
) -> None:
    with pytest.raises(error, match=f"^{named}"):
        _settings(**changes)
