"""The horizon bound's compiled kernels against the NumPy expressions they replace, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from infoseek.envs.sensors import BearingSensor, make_sensor
from infoseek.planners.horizon_affinity import AffinityTable, log_affinity, pair_term_sums
from infoseek.planners.horizon_bound import bound_rows
from infoseek.planners.horizon_information import HorizonInformation

PERIOD = 2.0 * math.pi


def _table(periodic: bool, rng: np.random.Generator) -> AffinityTable:
    """A random decreasing table on the grid the bearing (periodic) or range sensor uses."""
    n = 4096
    width = PERIOD if periodic else 100.0
    step = width / n if periodic else 2.0 * width / n
    values = -np.cumsum(rng.uniform(0.0, 0.05, n))
    return AffinityTable(values, -(n // 2) * step, step, PERIOD if periodic else None)


def _numpy_log_affinity(delta: np.ndarray, table: AffinityTable) -> np.ndarray:
    """The NumPy code of ``HorizonInformation.log_affinity`` before the kernels."""
    if table.periodic:
        delta = np.mod(delta + 0.5 * table.period, table.period) - 0.5 * table.period
    position = (delta - table.delta0) / table.step
    last = table.table.size - 1
    np.clip(position, 0.0, last - 1e-9, out=position)
    index = position.astype(np.intp)
    position -= index
    low = table.table[index]
    return low + position * (table.table[index + 1] - low)


def _numpy_pair_sums(predictions: np.ndarray, table: AffinityTable) -> np.ndarray:
    """``(G, H, N, N)`` lookups summed over ``H`` as the planner summed them."""
    delta = predictions[..., :, None] - predictions[..., None, :]
    return _numpy_log_affinity(delta, table).sum(axis=1)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("periodic", [True, False])
def test_log_affinity_is_the_numpy_expression(periodic: bool, rng) -> None:
    table = _table(periodic, rng)
    edges = np.array([0.0, -0.0, math.pi, -math.pi, PERIOD, -PERIOD, 1.5 * PERIOD, 3 * PERIOD])
    delta = np.concatenate([edges, rng.normal(0.0, 5.0, 20_000), rng.normal(0.0, 1e3, 200)])
    delta = np.concatenate([delta, np.nextafter(edges, np.inf), np.nextafter(edges, -np.inf)])
    assert _same_bits(log_affinity(delta, table), _numpy_log_affinity(delta.copy(), table))
    grid = delta[:300].reshape(3, 10, 10)
    assert _same_bits(log_affinity(grid, table), _numpy_log_affinity(grid.copy(), table))


@pytest.mark.parametrize(
    ("periodic", "low", "high"),
    [(True, -math.pi, math.pi), (True, -9.0, 9.0), (False, 0.0, 60.0)],
    ids=["bearings-in-domain", "outside-one-period", "range"],
)
def test_pair_term_sums_are_the_numpy_sums(periodic: bool, low: float, high: float, rng) -> None:
    table = _table(periodic, rng)
    predictions = rng.uniform(low, high, (7, 4, 33))
    predictions[1, 0] = predictions[0, 0]  # shared first poses, as sequences with one first control
    predictions[2, 0] = predictions[0, 0]
    predictions[4, 0] = predictions[0, 0]  # equal to an earlier, not the previous, group's
    predictions[5, :, 3] = predictions[5, :, 4]  # two particles with the same prediction
    edges = [-math.pi, 0.0, -0.0, np.nextafter(math.pi, 0.0), -math.pi / 2, math.pi / 2]
    predictions[6, 1, : len(edges)] = edges  # differences of exactly +-pi, +-pi/2 and 0
    expected = _numpy_pair_sums(predictions, table)
    assert _same_bits(pair_term_sums(predictions, table), expected)
    single = predictions[:, :1]  # H = 1: the terms of each group's one pose
    assert _same_bits(pair_term_sums(single, table), _numpy_pair_sums(single, table))


def test_bound_rows_are_the_numpy_log_sum_exp(rng) -> None:
    own = rng.normal(-30.0, 20.0, (11, 17, 17))
    own[3, 2, 5] = -2000.0  # an exponential that underflows
    partners = rng.normal(-10.0, 5.0, (3, 17, 17))
    weights = rng.dirichlet(np.ones(17))
    total = own + partners[0] + partners[1] + partners[2]
    shifted = total + np.log(weights)[None, :]
    top = shifted.max(axis=-1, keepdims=True)
    expected = np.log(np.exp(shifted - top).sum(axis=-1)) + top[..., 0]
    assert _same_bits(bound_rows(own, partners, np.log(weights)), expected)
    alone = own + np.log(weights)[None, :]
    peak = alone.max(axis=-1, keepdims=True)
    expected = np.log(np.exp(alone - peak).sum(axis=-1)) + peak[..., 0]
    assert _same_bits(bound_rows(own, np.empty((0, 17, 17)), np.log(weights)), expected)


def test_information_methods_keep_the_planners_numbers(rng) -> None:
    info = HorizonInformation(BearingSensor(0.1))
    particles = rng.uniform(0.0, 40.0, (24, 2))
    poses = rng.uniform(0.0, 40.0, (6, 5, 2))
    sums = info.pose_term_sums(particles, poses)
    terms = info.pose_terms(particles, poses.reshape(-1, 2)).reshape(6, 5, 24, 24)
    assert _same_bits(sums, terms.sum(axis=1))
    weights = rng.dirichlet(np.ones(24))
    partners = info.pose_term_sums(particles, poses[:2])
    expected = info.value(sums + partners[0] + partners[1], weights)
    assert _same_bits(info.bound(sums, partners, weights), expected)
    assert _same_bits(info.value(sums[0], weights), info.value(sums[:1], weights)[0])


def test_kernels_reject_wrong_dtypes_shapes_and_values(rng) -> None:
    table = _table(True, rng)
    with pytest.raises(TypeError, match="predictions must be a float64"):
        pair_term_sums(np.zeros((2, 3, 4), dtype=np.float32), table)
    with pytest.raises(ValueError, match="predictions must be \\(G, H >= 1, N\\)"):
        pair_term_sums(np.zeros((3, 4)), table)
    with pytest.raises(ValueError, match="predictions must be finite"):
        pair_term_sums(np.full((1, 1, 2), np.nan), table)
    with pytest.raises(TypeError, match="delta must be a float64"):
        log_affinity(np.zeros(3, dtype=np.int64), table)
    with pytest.raises(TypeError, match="affinity must be an AffinityTable"):
        log_affinity(np.zeros(3), "table")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="table must be"):
        AffinityTable(np.zeros(5, dtype=np.float32), 0.0, 1.0, None)
    with pytest.raises(ValueError, match="step"):
        AffinityTable(np.zeros(5), 0.0, 0.0, None)
    own, log_w = np.zeros((2, 4, 4)), np.zeros(4)
    with pytest.raises(TypeError, match="own must be a float64"):
        bound_rows(own.astype(np.float32), np.empty((0, 4, 4)), log_w)
    with pytest.raises(TypeError, match="log_weights must be a float64"):
        bound_rows(own, np.empty((0, 4, 4)), log_w.astype(np.float32))
    with pytest.raises(ValueError, match="partners must be"):
        bound_rows(own, np.zeros((1, 3, 4)), log_w)
    with pytest.raises(ValueError, match="own must be"):
        bound_rows(own[0], np.empty((0, 4, 4)), log_w)


def test_range_sensor_table_matches_its_numpy_lookup(rng) -> None:
    info = HorizonInformation(make_sensor("range"))
    delta = rng.normal(0.0, 30.0, 5000)
    assert _same_bits(info.log_affinity(delta), _numpy_log_affinity(delta.copy(), info._affinity))
