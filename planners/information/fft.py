r"""The fast estimator for additive-noise sensors: histograms of predictions, FFT convolution.

For an :class:`~infoseek.envs.sensors.base.AdditiveNoiseSensor`, ``z = wrap(predict + eta)``, the
observation density of the particle belief (eq. 15) is the weighted histogram of the particles'
noise-free predictions convolved with the noise density, and ``H(z | theta)`` (eq. 19) is ``k``
times the noise entropy. So no likelihood is evaluated: each pose costs one ``predict`` of the
``N`` particles, the predictions are spread over the grid with the three-point quadratic
stencil (:mod:`~infoseek.planners.information.noise_kernel`, no nearest-node rounding), and the
histogram is convolved by FFT, ``O(N 3^k + Q^k log Q)`` per pose set instead of ``O(N Q^k)``.

* one observation: one compiled pass of three moment histograms per pose
  (:mod:`~infoseek.planners.information.moment_histograms`) and one batched ``rfft``;
* pairs: windowed grids around each pose's predictions once the belief has concentrated
  (:mod:`~infoseek.planners.information.windows`), the full ``Q x Q`` grid otherwise (compiled
  histograms, :mod:`~infoseek.planners.information.pair_histograms`);
* three observations: the full ``Q^3`` grid.

The same grid serves every ``k`` (bearing sensor, ``sigma = 0.1``: 96 nodes), so single and pair
terms of a utility share one resolution. Predictions are computed once per pose and belief in
float32 (about ``1e-7`` of a node) and kept, with the window stencils, by the belief's
:class:`~infoseek.planners.information.stencil_cache.StencilCache`. Predictions outside a
non-periodic domain are clamped to its edge. The compiled kernels accumulate in the order of the
NumPy expressions they replaced, so every value is the same bit for bit in the pinned numerical
environment (:mod:`infoseek.envs.compiled`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information.base import BeliefMI, FloatArray, JointEntropies, MIEstimator
from infoseek.planners.information.channels import BATCH_BUDGET
from infoseek.planners.information.moment_histograms import single_stencil_histograms
from infoseek.planners.information.noise_kernel import NoiseKernel, grid_points
from infoseek.planners.information.quadrature import check_points
from infoseek.planners.information.sensor_cache import sensor_table
from infoseek.planners.information.stencil_cache import StencilCache
from infoseek.planners.information.windows import (
    full_grid_pair_entropies,
    windowed_pair_entropies,
)

__all__ = ["AdditiveFFTEstimator"]

_SINGLE_CHUNK_ELEMENTS = 1 << 20  # predictions per chunk of single MIs


class AdditiveFFTEstimator(MIEstimator):
    """Histogram + FFT estimator for additive-noise sensors (module docstring).

    Args:
        sensor: A sensor with ``predict`` and ``noise_log_density``.
        n_points: Grid nodes per observation (``None``: 1.5 per noise standard deviation, at
            least 32).
    """

    name: ClassVar[str] = "fft"
    required_methods: ClassVar[tuple[str, ...]] = ("predict", "noise_log_density")
    options: ClassVar[tuple[str, ...]] = ("n_points",)

    def __init__(self, sensor: Sensor, n_points: int | None = None) -> None:
        super().__init__(sensor)
        points = check_points(n_points)
        self.kernel = sensor_table(
            sensor,
            ("fft/noise-kernel", points),
            lambda: NoiseKernel(sensor, grid_points(sensor, points)),
        )
        self.log_spacing = math.log(self.kernel.spacing)

    @property
    def n_points(self) -> int:
        """Grid nodes per observation."""
        return self.kernel.n_points

    # -- per-pose work
    def cache(self, belief: BeliefMI) -> StencilCache:
        """The belief's predictions and window stencils (one :class:`StencilCache` per belief)."""
        return belief.derived(  # type: ignore[no-any-return]
            "fft/stencils", lambda: StencilCache(self.sensor, self.kernel, belief.particles)
        )

    def predictions(self, belief: BeliefMI, poses: FloatArray) -> NDArray[Any]:
        """``(P, N)`` float32 noise-free predictions, cached per pose."""
        return self.cache(belief).predictions(poses)

    # -- estimates
    def singles(self, belief: BeliefMI, poses: FloatArray) -> FloatArray:
        return self._single_entropies(belief, poses) - self.kernel.entropy

    def singles_of(
        self, beliefs: Sequence[BeliefMI], pose_sets: Sequence[FloatArray]
    ) -> list[FloatArray]:
        """:meth:`singles` of several beliefs, their grids convolved by one batched FFT (each
        row is transformed on its own, so the values are those of separate calls)."""
        sizes = [poses.shape[0] for poses in pose_sets]
        if sum(size * b.n_particles for size, b in zip(sizes, beliefs, strict=True)) > (
            _SINGLE_CHUNK_ELEMENTS
        ):
            return super().singles_of(beliefs, pose_sets)
        histograms = np.concatenate(
            [self._histograms(b, poses) for b, poses in zip(beliefs, pose_sets, strict=True)]
        )
        entropies = self.kernel.smoothed_entropy(histograms) - self.kernel.entropy
        return np.split(entropies, np.cumsum(sizes)[:-1])

    def _histograms(self, belief: BeliefMI, poses: FloatArray) -> FloatArray:
        """``(C, Q)`` single-observation stencil histograms of ``(C, pose_dim)`` poses."""
        kernel = self.kernel
        predictions = np.asarray(self.cache(belief).predictions(poses), dtype=np.float32)
        return single_stencil_histograms(
            predictions,
            belief.weights,
            belief.uniform,
            kernel.low,
            kernel.spacing,
            kernel.n_points,
            kernel.periodic,
        )

    def _single_entropies(self, belief: BeliefMI, poses: FloatArray) -> FloatArray:
        """Discrete ``H(z)`` of single observations at ``(C, pose_dim)`` poses."""
        chunk = max(1, _SINGLE_CHUNK_ELEMENTS // belief.n_particles)
        result = np.empty(poses.shape[0])
        for start in range(0, poses.shape[0], chunk):
            block = poses[start : start + chunk]
            histograms = self._histograms(belief, block)
            result[start : start + block.shape[0]] = self.kernel.smoothed_entropy(histograms)
        return result

    def pairs(self, belief: BeliefMI, poses_a: FloatArray, poses_b: FloatArray) -> FloatArray:
        cache = self.cache(belief)
        side_a, side_b = cache.sides(poses_a, poses_b)
        if side_a.fits and side_b.fits:
            joint = windowed_pair_entropies(
                self.kernel, side_a, side_b, belief.weights, belief.uniform
            )
        else:
            predictions = _exact_dtype(cache.predictions(np.concatenate([poses_a, poses_b])))
            joint = full_grid_pair_entropies(
                self.kernel,
                predictions[: poses_a.shape[0]],
                predictions[poses_a.shape[0] :],
                belief.weights,
            )
        return joint - 2.0 * self.kernel.entropy

    def joint(self, belief: BeliefMI, pose_sets: FloatArray) -> JointEntropies:
        n_sets, k = pose_sets.shape[:2]
        if k == 1:
            entropy = self._single_entropies(belief, pose_sets[:, 0])
        else:
            entropy = np.empty(n_sets)
            per_set = max(belief.n_particles * 3**k, self.kernel.length**k) * 4
            chunk = max(1, BATCH_BUDGET // per_set)
            for start in range(0, n_sets, chunk):
                block = pose_sets[start : start + chunk]
                assignments = [
                    self.kernel.assign(self.predictions(belief, block[:, j]).astype(np.float64))
                    for j in range(k)
                ]
                histograms = self.kernel.joint_histograms(assignments, belief.weights)
                entropy[start : start + block.shape[0]] = self.kernel.smoothed_entropy(histograms)
        log_cells = k * self.log_spacing
        return JointEntropies.from_entropies(
            entropy + log_cells, np.full(n_sets, k * self.kernel.entropy + log_cells)
        )


def _exact_dtype(predictions: NDArray[Any]) -> NDArray[Any]:
    """Float32 predictions as they are (the full-grid kernel widens them exactly), others as
    float64."""
    return predictions if predictions.dtype == np.float32 else predictions.astype(np.float64)
