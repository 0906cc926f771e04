"""The compiled kernels of the MI engine against the NumPy computations they replace.

Each reference below is the NumPy form the kernel replaced (``numpy.bincount`` histograms,
fancy-index scatters, masked updates); the kernels must reproduce it bit for bit, since stored
trials are re-run by ``infoseek verify`` and planner decisions depend on the last bits of the
utilities. Wrong dtypes and shapes must be refused with an error naming the argument.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from infoseek.envs.sensors import BearingSensor, RangeSensor
from infoseek.planners.information.moment_histograms import single_stencil_histograms
from infoseek.planners.information.noise_kernel import NoiseKernel, grid_points
from infoseek.planners.information.pair_histograms import (
    full_grid_pair_histograms,
    windowed_scatter_histograms,
)
from infoseek.planners.information.window_stencils import pose_windows, stencil_matrices

SENSORS = [BearingSensor(sigma=0.1), RangeSensor(sigma=0.5, max_range=60.0)]


def _same(a: Any, b: Any) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _kernel(sensor: Any) -> NoiseKernel:
    return NoiseKernel(sensor, grid_points(sensor))


def _predictions(kernel: NoiseKernel, rng: np.random.Generator, shape: tuple[int, int]) -> Any:
    """float32 predictions over and slightly beyond the domain, with the edges themselves."""
    low, high = kernel.low, kernel.low + kernel.n_points * kernel.spacing
    if not kernel.periodic:
        high = kernel.low + (kernel.n_points - 1) * kernel.spacing
    values = rng.uniform(low - 0.3, high + 0.3, shape).astype(np.float32)
    edges = np.array([low, high, np.nextafter(np.float32(high), 0), low - 1e-7], np.float32)
    values[0, : min(shape[1], 4)] = edges[: min(shape[1], 4)]
    return values


# ------------------------------------------------------------------------------- references
def _positions(kernel: NoiseKernel, predictions: Any, dtype: Any) -> Any:
    position = np.asarray(predictions, dtype=dtype) - dtype(kernel.low)
    position *= dtype(1.0 / kernel.spacing)
    if kernel.periodic:
        if position.size and (position.min() < 0.0 or position.max() >= kernel.n_points):
            position %= dtype(kernel.n_points)
    else:
        np.clip(position, 0.0, kernel.n_points - 1.0, out=position)
    return position


def _stencil_weights(delta: Any) -> Any:
    half_sq = 0.5 * delta * delta
    weights = np.empty(delta.shape + (3,), dtype=np.result_type(delta.dtype, np.float32))
    weights[..., 0] = half_sq - 0.5 * delta
    weights[..., 1] = 1.0 - 2.0 * half_sq
    weights[..., 2] = half_sq + 0.5 * delta
    return weights


def _reference_single(kernel: NoiseKernel, predictions: Any, weights: Any, uniform: bool) -> Any:
    q = kernel.n_points
    n_batch, n = predictions.shape
    position = _positions(kernel, predictions, np.float32)
    nearest = np.floor(position + np.float32(0.5))
    position -= nearest
    index = nearest.astype(np.intp) + (np.arange(n_batch) * (q + 1))[:, None]
    index, delta, size = index.ravel(), position.ravel(), n_batch * (q + 1)
    if uniform:
        mass = np.bincount(index, None, size) * (1.0 / n)
        first = np.bincount(index, delta, size) * (1.0 / n)
        second = np.bincount(index, delta * delta, size) * (1.0 / n)
    else:
        weighted = (position * weights).ravel()
        mass = np.bincount(index, np.tile(weights, n_batch), size)
        first = np.bincount(index, weighted, size)
        weighted *= delta
        second = np.bincount(index, weighted, size)
    moments = np.stack([mass, first, second]).reshape(3, n_batch, q + 1)
    moments[..., 0 if kernel.periodic else q - 1] += moments[..., q]
    mass, first, second = moments[..., :q]
    centre, up, down = mass - second, 0.5 * (second + first), 0.5 * (second - first)
    if kernel.periodic:
        return centre + np.roll(up, 1, axis=1) + np.roll(down, -1, axis=1)
    histogram = centre
    histogram[:, 1:] += up[:, :-1]
    histogram[:, -1] += up[:, -1]
    histogram[:, :-1] += down[:, 1:]
    histogram[:, 0] += down[:, 0]
    return histogram


def _reference_assign(kernel: NoiseKernel, predictions: Any) -> tuple[Any, Any]:
    position = _positions(kernel, predictions, np.float64)
    nearest_float = np.floor(position + 0.5)
    nearest = nearest_float.astype(np.intp)
    if kernel.periodic:
        nearest[nearest >= kernel.n_points] -= kernel.n_points
    return nearest, _stencil_weights(position - nearest_float)


def _reference_pairs(kernel: NoiseKernel, predictions_a: Any, predictions_b: Any, w: Any) -> Any:
    (near_a, weights_a), (near_b, weights_b) = (
        _reference_assign(kernel, predictions_a),
        _reference_assign(kernel, predictions_b),
    )
    q, padded = kernel.n_points, kernel.n_points + 2
    n_a, n_b = near_a.shape[0], near_b.shape[0]
    base = near_a[:, None, :] * padded + near_b[None, :, :]
    base += (np.arange(n_a * n_b) * padded * padded).reshape(n_a, n_b, 1)
    index = base[..., None] + (np.arange(3)[:, None] * padded + np.arange(3)[None, :]).ravel()
    values = (weights_a * w[:, None])[:, None, :, :, None] * weights_b[None, :, :, None, :]
    h = np.bincount(index.ravel(), values.ravel(), n_a * n_b * padded * padded)
    h = h.reshape(n_a, n_b, padded, padded)
    low, high = (q, 1) if kernel.periodic else (1, q)
    h[:, :, low, :] += h[:, :, 0, :]
    h[:, :, high, :] += h[:, :, q + 1, :]
    h[:, :, :, low] += h[:, :, :, 0]
    h[:, :, :, high] += h[:, :, :, q + 1]
    return h[:, :, 1 : q + 1, 1 : q + 1]


def _reference_windows(kernel: NoiseKernel, predictions: Any) -> tuple[Any, Any, Any, Any]:
    q = kernel.n_points
    position = _positions(kernel, predictions, np.float32)
    offsets = np.arange(-1, 2, dtype=np.int32)
    if kernel.periodic:
        half = np.float32(0.5 * q)
        deviation = position - position[:, :1]
        deviation[deviation < -half] += np.float32(q)
        deviation[deviation >= half] -= np.float32(q)
        lowest = deviation.min(axis=1).astype(np.float64) + position[:, 0]
        start = np.floor(lowest).astype(np.int64) - 1
        relative = position - start[:, None].astype(np.float32)
        relative[relative < 0] += np.float32(q)
        relative[relative >= q] -= np.float32(q)
        nearest_float = np.floor(relative + np.float32(0.5))
        delta = relative - nearest_float
        nearest = nearest_float.astype(np.intp)
        wrapped = nearest.min(axis=1) == 0
        start[wrapped] -= 1
        nearest[wrapped] += 1
        targets = nearest.astype(np.int32)[..., None] + offsets
    else:
        nearest_float = np.floor(position + np.float32(0.5))
        delta = position - nearest_float
        nearest = nearest_float.astype(np.intp)
        start = np.maximum(nearest.min(axis=1) - 1, 0).astype(np.int64)
        targets = np.clip(nearest[..., None] + offsets, 0, q - 1) - start[:, None, None]
        targets = targets.astype(np.int32)
    width = targets.max(axis=(1, 2)).astype(np.int64) + 1
    return start, targets, _stencil_weights(delta), width


def _reference_dense(targets: Any, weights: Any, width: int) -> Any:
    n_poses, n = targets.shape[:2]
    flat = (targets + (np.arange(n_poses) * width)[:, None, None]) * n + np.arange(n)[:, None]
    dense = np.zeros(n_poses * width * n, dtype=np.float32)
    dense[flat.ravel()] = weights.ravel()
    return dense.reshape(n_poses * width, n)


def _reference_scatter(side_a: tuple[Any, ...], side_b: tuple[Any, ...], w: Any) -> Any:
    (targets_a, weights_a, width_a), (targets_b, weights_b, width_b) = side_a, side_b
    n_a, n_b = targets_a.shape[0], targets_b.shape[0]
    flat = (
        (np.arange(n_a * n_b).reshape(n_a, n_b, 1, 1, 1) * width_a) + targets_a[:, None, :, :, None]
    ) * width_b + targets_b[None, :, :, None, :]
    weight = (weights_a * w[:, None])[:, None, :, :, None] * weights_b[None, :, :, None, :]
    counts = np.bincount(flat.ravel(), weight.ravel(), n_a * n_b * width_a * width_b)
    return counts.reshape(n_a, n_b, width_a, width_b).astype(np.float32)


# -------------------------------------------------------------------------------------- tests
@pytest.mark.parametrize("sensor", SENSORS, ids=["bearing", "range"])
@pytest.mark.parametrize("n", [1, 7, 2000])
@pytest.mark.parametrize("uniform", [True, False])
def test_single_histograms_equal_the_bincount_form_bit_for_bit(sensor, n, uniform):
    kernel = _kernel(sensor)
    rng = np.random.default_rng(n)
    predictions = _predictions(kernel, rng, (5, n))
    weights = np.full(n, 1.0 / n) if uniform else rng.gamma(1.0, size=n)
    weights = weights / weights.sum()
    expected = _reference_single(kernel, predictions, weights, uniform)
    histograms = single_stencil_histograms(
        predictions, weights, uniform, kernel.low, kernel.spacing, kernel.n_points, kernel.periodic
    )
    assert _same(histograms, expected)
    assert _same(kernel.single_histograms(predictions, weights, uniform), expected)
    # inside the domain only (no wrap pass), and the mass is conserved
    inside = predictions[1:]
    if kernel.periodic:
        inside = np.clip(inside, kernel.low, np.float32(np.pi) - np.float32(1e-3))
    assert _same(
        kernel.single_histograms(inside, weights, uniform),
        _reference_single(kernel, inside, weights, uniform),
    )
    np.testing.assert_allclose(histograms.sum(axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize("sensor", SENSORS, ids=["bearing", "range"])
@pytest.mark.parametrize("n", [1, 5, 300])
def test_full_grid_pair_histograms_equal_the_bincount_form_bit_for_bit(sensor, n):
    kernel = _kernel(sensor)
    rng = np.random.default_rng(10 + n)
    predictions_a = _predictions(kernel, rng, (4, n))
    predictions_b = _predictions(kernel, rng, (3, n))
    weights = rng.gamma(1.0, size=n)
    weights /= weights.sum()
    args = (kernel.low, kernel.spacing, kernel.n_points, kernel.periodic)
    for a, b in (
        (predictions_a, predictions_b),
        (predictions_a.astype(np.float64) * 1.01, predictions_b.astype(np.float64)),
    ):
        expected = _reference_pairs(kernel, a, b, weights)
        assert _same(full_grid_pair_histograms(a, b, weights, *args), expected)


@pytest.mark.parametrize("sensor", SENSORS, ids=["bearing", "range"])
@pytest.mark.parametrize("spread", [0.01, 0.3, 2.0, 10.0])
def test_pose_windows_and_stencil_matrices_equal_the_numpy_form_bit_for_bit(sensor, spread):
    kernel = _kernel(sensor)
    rng = np.random.default_rng(int(spread * 100))
    low, high = float(sensor.domain.low[0]), float(sensor.domain.high[0])
    predictions = rng.uniform(low, high, (6, 1)) + rng.normal(0.0, spread, (6, 400))
    if kernel.periodic:
        predictions = (predictions - low) % (high - low) + low
    predictions = predictions.astype(np.float32)
    predictions[1, :2] = [high - 1e-7, low]
    expected = _reference_windows(kernel, predictions)
    windows = pose_windows(
        predictions, kernel.low, kernel.spacing, kernel.n_points, kernel.periodic
    )
    assert all(_same(got, want) for got, want in zip(windows, expected, strict=True))
    width = int(windows[3].max())
    assert _same(
        stencil_matrices(windows[1], windows[2], width), _reference_dense(*expected[1:3], width)
    )


def test_dense_stencils_keep_the_last_of_two_entries_at_a_clamped_edge():
    targets = np.array([[[0, 0, 1], [2, 3, 3]]], dtype=np.int32)  # clamped stencils
    weights = np.array([[[0.25, 0.5, 0.25], [0.125, 0.75, 0.125]]], dtype=np.float32)
    dense = stencil_matrices(targets, weights, 4)
    assert _same(dense, _reference_dense(targets, weights, 4))
    assert dense[0, 0] == np.float32(0.5) and dense[3, 1] == np.float32(0.125)


def test_windowed_scatter_histograms_equal_the_bincount_form_bit_for_bit():
    kernel = _kernel(SENSORS[0])
    rng = np.random.default_rng(4)
    n = 250
    weights = rng.gamma(1.0, size=n)
    weights /= weights.sum()
    sides = []
    for centre, count in ((0.3, 3), (1.4, 2)):
        predictions = (centre + rng.normal(0.0, 0.4, (count, n))).astype(np.float32)
        _, targets, stencils, width = pose_windows(
            predictions, kernel.low, kernel.spacing, kernel.n_points, kernel.periodic
        )
        sides.append((targets, stencils, int(width.max())))
    expected = _reference_scatter(sides[0], sides[1], weights)
    (targets_a, weights_a, width_a), (targets_b, weights_b, width_b) = sides
    got = windowed_scatter_histograms(
        targets_a, weights_a, targets_b, weights_b, weights, width_a, width_b
    )
    assert _same(got, expected)


def test_kernels_refuse_wrong_dtypes_and_shapes_naming_the_argument():
    kernel = _kernel(SENSORS[0])
    args = (kernel.low, kernel.spacing, kernel.n_points, kernel.periodic)
    predictions = np.zeros((2, 10), dtype=np.float32)
    weights = np.full(10, 0.1)
    with pytest.raises(TypeError, match="predictions must have dtype float32"):
        single_stencil_histograms(predictions.astype(np.float64), weights, False, *args)
    with pytest.raises(TypeError, match="weights must have dtype float64"):
        single_stencil_histograms(predictions, weights.astype(np.float32), False, *args)
    with pytest.raises(ValueError, match=r"weights must have shape \(10\)"):
        single_stencil_histograms(predictions, weights[:5], False, *args)
    with pytest.raises(TypeError, match="predictions_b must have dtype float32"):
        full_grid_pair_histograms(predictions, predictions.astype(np.float64), weights, *args)
    with pytest.raises(ValueError, match="predictions_b must have shape"):
        full_grid_pair_histograms(predictions, predictions[:, :4], weights, *args)
    with pytest.raises(TypeError, match="predictions must be a numpy array"):
        pose_windows([[0.0]], *args)  # type: ignore[arg-type]
    targets = np.zeros((1, 10, 3), dtype=np.int32)
    with pytest.raises(TypeError, match="targets must have dtype int32"):
        stencil_matrices(targets.astype(np.int64), np.zeros((1, 10, 3), np.float32), 2)
    with pytest.raises(ValueError, match=r"targets must lie in \[0, 2\)"):
        stencil_matrices(targets + 2, np.zeros((1, 10, 3), np.float32), 2)
    with pytest.raises(ValueError, match="weights_b must have shape"):
        windowed_scatter_histograms(
            targets,
            np.zeros((1, 10, 3), np.float32),
            targets,
            np.zeros((2, 10, 3), np.float32),
            weights,
            2,
            2,
        )


def test_pose_rows_compute_each_pose_once_and_start_again_past_the_budget():
    from infoseek.planners.information.pose_rows import PoseRows

    calls: list[int] = []

    def compute(poses: Any) -> dict[str, Any]:
        calls.append(poses.shape[0])
        return {"value": poses.sum(axis=1, keepdims=True) * np.ones((1, 4))}

    table = PoseRows(budget=1 << 20)
    poses = np.array([[1.0, 2.0], [3.0, 4.0], [1.0, 2.0]])  # a repeated pose
    rows = table.lookup(poses, compute)
    assert calls == [3]  # the batch as requested
    block = table.take("value", table.lookup(poses[1:], compute))  # rows 1, 2 of one block
    assert calls == [3] and block.base is not None  # computed together: a view
    np.testing.assert_array_equal(table.take("value", rows)[:, 0], [3.0, 7.0, 3.0])
    more = table.lookup(np.array([[3.0, 4.0], [5.0, 6.0]]), compute)
    assert calls == [3, 1]
    np.testing.assert_array_equal(table.take("value", more)[:, 0], [7.0, 11.0])
    small = PoseRows(budget=96)  # three rows of 4 float64 fit, a fourth starts again
    small.lookup(poses, compute)
    before = small.take("value", small.lookup(poses[1:2], compute))
    again = small.lookup(np.array([[7.0, 8.0], [1.0, 2.0]]), compute)
    assert small.generation == 1 and small.nbytes == 64
    np.testing.assert_array_equal(small.take("value", again)[:, 0], [15.0, 3.0])
    np.testing.assert_array_equal(before[0], 7.0)  # arrays handed out earlier stay valid


@pytest.mark.parametrize("length", [1, 9, 1200, 8192, 8193, 9216, 20000])
def test_grid_entropies_equal_the_numpy_form_bit_for_bit(length):
    from infoseek.planners.information.grid_entropy import (
        entropy_sums,
        float32_grid_entropies,
        normalise_rows,
    )

    rng = np.random.default_rng(length)
    grids = rng.standard_normal((3, length)) * np.exp(rng.uniform(-30.0, 5.0, (3, length)))
    grids[:, 0] = -0.0
    # float64 (the FFT grids): clamp at 0, normalise (sum floored at 1e-30), clamp at 1e-300
    density = np.maximum(grids, 0.0)
    density /= np.maximum(density.sum(axis=1, keepdims=True, dtype=np.float64), 1e-30)
    density = np.maximum(density, 1e-300)
    expected = -np.sum(density * np.log(density), axis=(1,))
    rows = grids.copy()
    normalise_rows(rows)
    assert _same(rows, density)
    assert _same(entropy_sums(rows, np.log(rows)), expected)
    # float32 (the window grids): clamp at 1e-38, normalise by the float64 sum in float32
    grids32 = grids.astype(np.float32)
    density32 = np.maximum(grids32, np.float32(1e-38))
    density32 /= density32.sum(axis=1, keepdims=True, dtype=np.float64).astype(np.float32)
    expected32 = -np.sum(density32 * np.log(density32), axis=1, dtype=np.float64)
    rows32 = grids32.copy()
    normalise_rows(rows32)
    assert _same(rows32, density32)
    assert _same(entropy_sums(rows32, np.log(rows32)), expected32)
    rows32 = grids32.copy()
    assert _same(float32_grid_entropies(rows32), expected32)
    assert _same(rows32, density32)
    # subnormal cells other than the floor (distinct values, runs of equal ones), a row whose
    # floor quotient is normal (its sum below 0.85) and one of a single cell
    tiny = np.arange(1, 1 << 23, 997, dtype=np.int32).view(np.float32)
    cells = rng.choice(grids32.size, size=min(tiny.size, grids32.size // 2), replace=False)
    grids32.reshape(-1)[cells] = tiny[: cells.size]
    grids32[:, 1 : min(4, length)] = tiny[-1]
    grids32[2] *= np.float32(1e-3) / max(grids32[2].max(), np.float32(1e-30))
    for grid in (grids32, grids32[:, :1]):
        density32 = np.maximum(grid, np.float32(1e-38))
        density32 /= density32.sum(axis=1, keepdims=True, dtype=np.float64).astype(np.float32)
        expected32 = -np.sum(density32 * np.log(density32), axis=1, dtype=np.float64)
        rows32 = grid.copy()
        assert _same(float32_grid_entropies(rows32), expected32)
        assert _same(rows32, density32)
        rows32 = grid.copy()
        normalise_rows(rows32)
        assert _same(rows32, density32)
        assert _same(entropy_sums(rows32, np.log(rows32)), expected32)
    with pytest.raises(TypeError, match="rows must be a float64 or float32"):
        normalise_rows(grids.astype(np.float16))
    with pytest.raises(ValueError, match="logs must have shape"):
        entropy_sums(rows, np.log(rows)[:2])


_LOGARITHM_CHECK = """
import numpy as np
rng = np.random.default_rng(7)
subnormal = np.arange(1, 1 << 23, dtype=np.int32).view(np.float32)
normal = rng.uniform(1e-30, 2.0, subnormal.size).astype(np.float32)
special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, -1e-40, -2.0, 1.0], dtype=np.float32)
values = np.concatenate([subnormal, normal, special])
rng.shuffle(values)
with np.errstate(all="ignore"):
    logs = np.log(values)
    same = all(
        np.log(values[order]).tobytes() == logs[order].tobytes()
        for order in (rng.permutation(values.size), np.arange(values.size)[::-1])
    )
    for start in rng.integers(0, values.size - 8, 2000):
        for stop in (start + 1, start + 3, start + 8):
            same = same and np.log(values[start:stop]).tobytes() == logs[start:stop].tobytes()
print("same" if same else "different")
"""


@pytest.mark.parametrize("pinned", [False, True], ids=["native", "pinned"])
def test_numpys_float32_log_of_an_element_depends_on_that_element_alone(
    pinned: bool, fresh_python: Callable[..., Any]
) -> None:
    """``float32_grid_entropies`` takes NumPy's log of each row's floor quotient apart from the
    row: the same bits only if NumPy's loop computes each element from that element alone
    (not from its neighbours or its lane), whichever SIMD target it dispatches to. All 2^23 - 1
    positive subnormals shuffled among normal and special values, permuted and in short
    slices, in this process's NumPy and in the pinned environment of stored trials (a fresh
    interpreter: the pin must precede NumPy's import)."""
    done = fresh_python(_LOGARITHM_CHECK, pinned=pinned)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "same"


def test_complex_multiply_is_numpy_complex64_multiply_bit_for_bit():
    from infoseek.envs.compiled import kernel
    from infoseek.planners.information.fused import complex_multiply

    @kernel
    def products(a: Any, b: Any) -> Any:  # pragma: no cover - compiled
        out = np.empty_like(a)
        for i in range(a.shape[0]):
            real, imag = complex_multiply(a[i].real, a[i].imag, b[i].real, b[i].imag)
            out[i] = complex(real, imag)
        return out

    rng = np.random.default_rng(9)
    for n in (1, 3, 8, 2001):
        a = (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)
        b = (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)
        assert _same(products(a, b), a * b)  # a rounding of the plain formula differs often


@pytest.mark.parametrize("max_snr", [5.0, 40.0])
def test_fourier_spectra_equal_the_numpy_synthesis_bit_for_bit(max_snr):
    from infoseek.envs.sensors.beacon import BeaconSensor
    from infoseek.planners.information import make_estimator

    sensor = BeaconSensor().with_max_snr(max_snr)
    compiled = make_estimator("fourier", sensor)
    reference = make_estimator("fourier", sensor)
    reference.table.compiled = False  # the NumPy form the kernel replaced
    assert compiled.table.compiled
    rng = np.random.default_rng(int(max_snr))
    particles = np.column_stack(
        [rng.uniform(0, 40, (700, 2)), rng.uniform(-np.pi, np.pi, (700, 1))]
    )
    belief = compiled.bind(particles, np.full(700, 1.0 / 700))
    poses = rng.uniform(0, 40, (5, 2))
    spectra, entropies = compiled._spectra(poses, belief)
    expected_spectra, expected_entropies = reference._spectra(poses, belief)
    assert _same(spectra, expected_spectra)
    assert _same(entropies, expected_entropies)


def test_pair_grids_equal_the_numpy_transpose_bit_for_bit():
    from infoseek.planners.information.grid_entropy import pair_grids

    rng = np.random.default_rng(12)
    n_a, n_b, q = 3, 4, 6
    joint = (rng.standard_normal((n_a * q, n_b * q)) * 1e-3).astype(np.float32)
    joint[0, :3] = [0.0, -0.0, 1e-310]
    expected = joint.reshape(n_a, q, n_b, q).astype(np.float64)
    expected = np.maximum(np.transpose(expected, (0, 2, 1, 3)).reshape(n_a * n_b, q * q), 1e-300)
    assert _same(pair_grids(joint, n_a, n_b, q), expected)
    with pytest.raises(ValueError, match="joint must have shape"):
        pair_grids(joint, n_a, n_b + 1, q)


def test_filter_spectra_equals_numpy_in_place_products_bit_for_bit():
    from infoseek.planners.information.spectral_filter import filter_spectra

    rng = np.random.default_rng(14)
    spectra = rng.standard_normal((4, 96, 49)) + 1j * rng.standard_normal((4, 96, 49))
    full = rng.standard_normal(96) + 1j * rng.standard_normal(96)
    half = rng.standard_normal(49) + 1j * rng.standard_normal(49)
    expected = spectra.copy()
    expected *= full.reshape(1, -1, 1)
    expected *= half.reshape(1, 1, -1)
    filter_spectra(spectra, full, half)
    assert _same(spectra, expected)
    with pytest.raises(ValueError, match="half must have shape"):
        filter_spectra(spectra, full, half[:5])


def test_smoothed_entropy_keeps_its_float32_option_on_pair_grids():
    kernel = _kernel(SENSORS[0])
    rng = np.random.default_rng(15)
    grids = rng.random((3, kernel.n_points, kernel.n_points))
    grids /= grids.sum(axis=(1, 2), keepdims=True)
    exact = kernel.smoothed_entropy(grids)
    single = kernel.smoothed_entropy(grids, dtype=np.float32)
    assert single.dtype == np.float64
    np.testing.assert_allclose(single, exact, rtol=1e-5)


def test_sensor_tables_are_built_once_per_sensor_object():
    import gc

    from infoseek.planners.information import make_estimator
    from infoseek.planners.information.sensor_cache import sensor_table

    sensor = BearingSensor(sigma=0.1)
    first = make_estimator("fft", sensor)
    assert make_estimator("fft", sensor).kernel is first.kernel
    assert make_estimator("fft", sensor, n_points=128).kernel is not first.kernel
    assert make_estimator("fft", BearingSensor(sigma=0.1)).kernel is not first.kernel
    builds: list[int] = []

    class Unhashable:
        __hash__ = None  # type: ignore[assignment]

    for _ in range(2):
        sensor_table(Unhashable(), "key", lambda: builds.append(1))
    assert len(builds) == 2  # built every time, never shared
    kernel = first.kernel
    del sensor, first
    gc.collect()
    assert make_estimator("fft", BearingSensor(sigma=0.1)).kernel is not kernel


def test_single_many_equals_separate_single_calls_bit_for_bit():
    from infoseek.planners.information import make_estimator
    from infoseek.planners.information.base import single_many

    sensor = BearingSensor(sigma=0.1)
    estimator = make_estimator("fft", sensor)
    rng = np.random.default_rng(16)
    inputs = []
    for n in (300, 700, 1200):
        particles = rng.normal(rng.uniform(5, 35, 2), rng.uniform(0.5, 8.0), (n, 2))
        inputs.append((particles, rng.gamma(1.0, size=n) if n != 700 else np.ones(n)))
    beliefs = [estimator.bind(particles, weights) for particles, weights in inputs]
    pose_sets = [rng.uniform(0, 40, (k, 2)) for k in (9, 4, 1)]
    together = single_many(beliefs, pose_sets)
    fresh = [estimator.bind(particles, weights) for particles, weights in inputs]
    for got, belief, poses in zip(together, fresh, pose_sets, strict=True):
        assert _same(got, belief.single(poses))
    other = make_estimator("quadrature", sensor).bind(beliefs[0].particles, beliefs[0].weights)
    with pytest.raises(ValueError, match="one estimator"):
        single_many([beliefs[0], other], pose_sets[:2])
    with pytest.raises(ValueError, match="one pose set per belief"):
        single_many(beliefs, pose_sets[:2])
