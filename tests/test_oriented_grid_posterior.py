"""The exact 3-D grid posterior (infoseek.envs.oriented_grid_posterior) against independent
computations: the beacon likelihood's axial symmetry, the compiled beacon kernel against the
sensor's own density, a tiny grid against direct summation of the likelihood, the uniform
density's disk mass, a Gaussian times von Mises posterior in closed form, pruning, and bad
input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import special

from infoseek.envs import make
from infoseek.envs.beacon_grid_kernel import beacon_cell_log_likelihood
from infoseek.envs.grid_posterior import GridPosterior
from infoseek.envs.oriented_grid_posterior import OrientedGridPosterior
from infoseek.envs.sensors.beacon import BeaconSensor

SIDE = 10.0


def _beacon_cases(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` beacons, 5 receivers (one exactly on a beacon, one 0.01 away) and 5 readings."""
    targets = np.column_stack([rng.uniform(0, SIDE, (n, 2)), rng.uniform(0, 2 * math.pi, n)])
    poses = rng.uniform(0, SIDE, (5, 2))
    poses[0] = targets[0, :2]
    poses[1] = targets[1, :2] + 0.01
    z = rng.uniform(0, math.pi, 5)
    return targets, poses, z


@pytest.mark.parametrize("max_snr", [5.0, math.inf])
def test_the_beacon_likelihood_is_axial(max_snr: float) -> None:
    """log p(z | x, y, psi) = log p(z | x, y, psi + pi): the field flips sign, the folded
    density does not see it (why the grid covers psi in [0, pi) only)."""
    rng = np.random.default_rng(1)
    sensor = BeaconSensor(max_snr=max_snr)
    targets, poses, z = _beacon_cases(rng, 400)
    turned = targets + np.array([0.0, 0.0, math.pi])
    a = sensor.log_likelihood(z[:, None], poses, targets)
    b = sensor.log_likelihood(z[:, None], poses, turned)
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("max_snr", [5.0, 50.0, math.inf])
def test_the_kernel_is_the_sensors_density(max_snr: float) -> None:
    """The compiled sum over readings equals BeaconSensor.log_likelihood summed over readings
    (to rounding; with the uncapped sensor the densities reach -1e11 near the receivers)."""
    rng = np.random.default_rng(2)
    sensor = BeaconSensor(max_snr=max_snr)
    positions = np.column_stack([rng.uniform(0, SIDE, 50), rng.uniform(0, SIDE, 50)])
    psi = np.sort(rng.uniform(0, math.pi, 7))
    _, poses, z = _beacon_cases(rng, 2)
    poses[0], poses[1] = positions[3], positions[4] + 0.01
    cells = np.sort(rng.choice(positions.shape[0] * psi.size, 200, replace=False)).astype(np.intp)
    got = beacon_cell_log_likelihood(sensor, cells, positions, psi, poses, z)
    states = np.column_stack([positions[cells // psi.size], psi[cells % psi.size]])
    want = sensor.log_likelihood(z[:, None], poses, states).sum(axis=0)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-11)


def test_the_kernel_rejects_bad_arrays() -> None:
    sensor = BeaconSensor()
    positions, psi = np.zeros((4, 2)), np.array([0.1, 0.2])
    with pytest.raises(ValueError, match="cells"):
        beacon_cell_log_likelihood(sensor, np.array([0.0]), positions, psi, np.zeros((1, 2)), [0])
    with pytest.raises(ValueError, match="cells"):
        beacon_cell_log_likelihood(
            sensor, np.array([8], dtype=np.intp), positions, psi, np.zeros((1, 2)), [0.0]
        )
    with pytest.raises(ValueError, match="poses"):
        beacon_cell_log_likelihood(
            sensor, np.array([1], dtype=np.intp), positions, psi, np.zeros((1, 3)), [0.0]
        )


class _Generic:
    """A sensor the grid only knows by its ``log_likelihood`` (the block path)."""

    def __init__(self, sensor: object) -> None:
        self.sensor = sensor

    def log_likelihood(self, z: np.ndarray, poses: np.ndarray, particles: np.ndarray) -> object:
        return self.sensor.log_likelihood(z, poses, particles)  # type: ignore[attr-defined]


@pytest.mark.parametrize("generic", [False, True])
def test_a_tiny_grid_is_the_direct_sum(generic: bool) -> None:
    """Two updates (one with a reading not received) on a 5 x 4 x 6 grid: the log posterior is
    the normalised sum of the sensor's log densities at the centres written out here; the
    position marginal, MMSE and mass of a disk follow from it by direct sums."""
    sensor = BeaconSensor(max_snr=5.0)
    grid = OrientedGridPosterior((0.0, 0.0), (5.0, 4.0), cells=(5, 4), orientation_cells=6)
    readings = [
        (np.array([[1.0, 1.5], [3.2, 0.4]]), np.array([[0.3], [2.9]]), np.array([True, True])),
        (np.array([[2.2, 2.0], [9.0, 9.0]]), np.array([[1.1], [0.2]]), np.array([True, False])),
    ]
    xs, ys, ps = np.meshgrid(
        np.arange(5) + 0.5, np.arange(4) + 0.5, (np.arange(6) + 0.5) * math.pi / 6, indexing="ij"
    )
    states = np.column_stack([xs.ravel(), ys.ravel(), ps.ravel()])
    log = np.zeros(states.shape[0])
    for poses, z, received in readings:
        grid.update(_Generic(sensor) if generic else sensor, poses, z, received)
        for pose, reading in zip(poses[received], z[received], strict=True):
            log += sensor.log_likelihood(reading[None], pose[None], states)[0]
    want = log - special.logsumexp(log)
    np.testing.assert_allclose(grid.log_posterior.ravel(), want, rtol=0, atol=1e-12)
    mass = np.exp(want).reshape(5, 4, 6)
    np.testing.assert_allclose(grid.position_marginal(), mass.sum(axis=2), atol=1e-14)
    np.testing.assert_allclose(grid.orientation_marginal(), mass.sum(axis=(0, 1)), atol=1e-14)
    weights = np.exp(want)
    doubled = np.angle(np.sum(weights * np.exp(2j * states[:, 2])))
    expected = np.array([*(weights @ states[:, :2]), (doubled / 2) % math.pi])
    np.testing.assert_allclose(grid.mmse(), expected, atol=1e-12)
    # a disk of radius 1.2 around (2, 2): cells whose every point is inside count whole; the
    # fractional ones are the 2-D rule's (tested in test_grid_posterior), here on the marginal
    marginal = mass.sum(axis=2)
    inside = sum(
        marginal[i, j]
        for i in range(5)
        for j in range(4)
        if math.hypot(i + 0.5 - 2.0, j + 0.5 - 2.0) + math.sqrt(0.5) <= 1.2
    )
    assert grid.mass_within(1.2, (2.0, 2.0)) >= inside - 1e-15
    assert grid.mass_within(30.0, (2.0, 2.0)) == pytest.approx(1.0, abs=1e-12)


def test_mass_within_a_uniform_density_is_the_disk_area() -> None:
    """At the prior, the mass of a disk inside the box is pi r^2 over the box's area (to the
    sub-cell sampling's accuracy, as in 2-D), whatever the orientation cells, and the 2-D
    grid's mass of the same disk to rounding."""
    grid = OrientedGridPosterior((0.0, 0.0), (SIDE, SIDE), cells=100, orientation_cells=4)
    flat = GridPosterior((0.0, 0.0), (SIDE, SIDE), cells=100)
    for radius, centre in ((1.0, (5.0, 5.0)), (2.345, (4.1, 6.03))):
        want = math.pi * radius**2 / SIDE**2
        assert grid.mass_within(radius, centre) == pytest.approx(want, rel=1e-3)
        assert grid.mass_within(radius, centre) == pytest.approx(
            flat.mass_within(radius, centre), rel=1e-12
        )
    np.testing.assert_allclose(grid.mmse()[:2], (5.0, 5.0), atol=1e-12)
    assert grid.entropy() == pytest.approx(math.log(SIDE * SIDE * math.pi), abs=1e-9)


class _GaussianVonMises:
    """A 3-D sensor with a closed-form posterior: z = (x, y) + N(0, s^2 I) and an axial
    reading of psi with density proportional to exp(kappa cos 2 (z_psi - psi))."""

    def __init__(self, s: float, kappa: float) -> None:
        self.s, self.kappa = s, kappa

    def log_likelihood(self, z: np.ndarray, poses: np.ndarray, particles: np.ndarray) -> object:
        del poses
        d2 = (particles[:, 0] - z[:, 0, None]) ** 2 + (particles[:, 1] - z[:, 1, None]) ** 2
        return -0.5 * d2 / self.s**2 + self.kappa * np.cos(2 * (z[:, 2, None] - particles[:, 2]))


def test_a_gaussian_times_von_mises_posterior() -> None:
    """One reading of the sensor above (s = 0.5, kappa = 8, psi read at 0.03: the axial
    posterior wraps around 0): the mass within 1 of the MMSE is 1 - exp(-1 / (2 s^2)), the
    MMSE position is the reading and the orientation estimate 0.03, and the doubled angle's
    mean resultant length is the von Mises one."""
    s, kappa = 0.5, 8.0
    grid = OrientedGridPosterior(
        (0.0, 0.0), (SIDE, SIDE), cells=200, orientation_cells=32, prune=700.0
    )
    reading = np.array([[4.93, 5.12, 0.03]])
    grid.update(_GaussianVonMises(s, kappa), [[0.0, 0.0]], reading, np.array([True]))
    estimate = grid.mmse()
    np.testing.assert_allclose(estimate, reading[0], atol=1e-9)
    want = 1.0 - math.exp(-1.0 / (2 * s * s))
    assert grid.mass_within(1.0, estimate[:2]) == pytest.approx(want, abs=1e-3)
    # the midpoint rule on the periodic angle is the trapezoidal rule: the mean resultant
    # length of the doubled angle is I1(kappa) / I0(kappa) to far below the position's error
    marginal = grid.orientation_marginal()
    resultant = marginal @ np.cos(2 * (grid.orientations - 0.03))
    assert resultant == pytest.approx(special.i1(kappa) / special.i0(kappa), abs=1e-10)


def test_pruning_drops_only_negligible_cells() -> None:
    """With prune = 30 the summaries agree with the unpruned grid to e^-30 per cell, and the
    pruned cells read -inf."""
    sensor = BeaconSensor(max_snr=5.0)
    rng = np.random.default_rng(3)
    beacon = np.array([[6.3, 4.1, 0.9]])
    full = OrientedGridPosterior((0, 0), (SIDE, SIDE), cells=60, orientation_cells=16)
    pruned = OrientedGridPosterior((0, 0), (SIDE, SIDE), cells=60, orientation_cells=16, prune=30)
    for _ in range(6):
        poses = rng.uniform(3, 8, (3, 2))
        z = sensor.sample(poses, beacon, rng)
        for grid in (full, pruned):
            grid.update(sensor, poses, z, np.ones(3, dtype=bool))
    assert pruned.n_active < full.n_active
    estimate = full.mmse()
    np.testing.assert_allclose(pruned.mmse(), estimate, atol=1e-9)
    assert pruned.mass_within(1.0, estimate[:2]) == pytest.approx(
        full.mass_within(1.0, estimate[:2]), abs=1e-9
    )
    assert np.isneginf(pruned.log_posterior).sum() == full.log_posterior.size - pruned.n_active


def test_from_config_and_bad_input() -> None:
    config = make("beacon_v0").unwrapped.config
    grid = OrientedGridPosterior.from_config(config, cells=20, orientation_cells=8)
    assert grid.shape == (20, 20, 8) and grid.period == pytest.approx(math.pi)
    assert grid.cell_of((0.05, 39.99, math.pi + 0.1)) == (0, 19, 0)
    with pytest.raises(ValueError, match="state"):
        grid.cell_of((40.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="config"):
        OrientedGridPosterior.from_config(make("bearings_v0").unwrapped.config)
    with pytest.raises(ValueError, match="orientation_cells"):
        OrientedGridPosterior((0, 0), (1, 1), orientation_cells=1)
    with pytest.raises(ValueError, match="period"):
        OrientedGridPosterior((0, 0), (1, 1), period=math.inf)
    with pytest.raises(ValueError, match="prune"):
        OrientedGridPosterior((0, 0), (1, 1), prune=-1.0)
    with pytest.raises(TypeError, match="sensor"):
        grid.update(object(), [[1.0, 1.0]], [[0.1]], np.array([True]))
    with pytest.raises(ValueError, match="received"):
        grid.update(config.filter_sensor, [[1.0, 1.0]], [[0.1]], [1])
    with pytest.raises(ValueError, match="poses"):
        grid.update(config.filter_sensor, [[1.0, 1.0, 0.0]], [[0.1]], np.array([True]))
    with pytest.raises(ValueError, match="radius"):
        grid.mass_within(0.0, (1.0, 1.0))
    assert grid.update(config.filter_sensor, [[1.0, 1.0]], [[0.1]], np.array([False])) == 0.0
