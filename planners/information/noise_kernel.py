r"""The additive noise density on a grid, and the assignment of predictions to its nodes.

For an additive-noise sensor ``z = wrap(predict + eta)`` the observation density of a particle
belief is the weighted histogram of the noise-free predictions convolved with the noise density
(eq. 15). :class:`NoiseKernel` holds the noise density discretised on ``Q`` equally spaced
nodes (periodic domains: ``Q`` nodes per period, circular convolution; other domains: zero
padding to the kernel's support) and its spectrum for FFT convolution.

**Assignment.** A prediction at fractional node position ``j + delta`` (``j`` the nearest node,
``|delta| <= 1/2``) is spread over nodes ``j - 1, j, j + 1`` with the three-point quadratic
(Lagrange) weights ``delta (delta - 1) / 2``, ``1 - delta^2``, ``delta (delta + 1) / 2``. They
preserve the particle's mass, mean and second moment, so the assignment adds no smoothing to
leading order; the residual error is third order in ``spacing / noise_std`` and odd in
``delta`` (it averages out over particles). There is no rounding of a prediction to its nearest
node. For one observation the histogram is formed from three moment histograms
``h_m[j] = sum_{n -> j} w_n delta_n^m`` (``m = 0, 1, 2``), accumulated in one compiled pass over
the particles (:mod:`~infoseek.planners.information.moment_histograms`): node ``q`` receives
``h_0 - h_2`` from its own particles, ``(h_2 + h_1) / 2`` from those of node ``q - 1`` and
``(h_2 - h_1) / 2`` from those of node ``q + 1``. Pairs of observations are accumulated the same
way on the two-dimensional grid (:mod:`~infoseek.planners.information.pair_histograms`), and the
convolved grids are normalised and turned into entropies by compiled passes around NumPy's
``log`` (:mod:`~infoseek.planners.information.grid_entropy`).

**Grid.** ``Q = width * ppstd / noise_std`` nodes, rounded up to an FFT-friendly size, with
``ppstd = 1.5`` points per noise standard deviation (the noise scale is measured once from
``noise_log_density``) and at least 32 nodes; the same grid for one, two and three observations,
so every term of a utility has one resolution (bearing sensor, ``sigma = 0.1``: 96 nodes).
The shared estimator tests (``tests/test_estimators.py``) bound the error against a fine
quadrature of the exact mixture.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import scipy.fft
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.channels import entropy
from infoseek.planners.information.grid_entropy import entropy_sums, normalise_rows
from infoseek.planners.information.moment_histograms import single_stencil_histograms
from infoseek.planners.information.quadrature import observation_nodes
from infoseek.planners.information.spectral_filter import filter_spectra

__all__ = ["NoiseKernel", "grid_points", "noise_std"]

#: Grid points per noise standard deviation.
POINTS_PER_STD = 1.5
#: Fewest grid nodes.
MIN_POINTS = 32
#: Largest grid for three joint observations (``Q^3`` cells).
MAX_GRID_CELLS = 1 << 22
#: Noise mass a windowed grid may discard beyond its kernel support.
WINDOW_TAIL_MASS = 1e-10


def noise_std(sensor: Sensor) -> float:
    """Standard deviation of an additive-noise sensor's noise, measured from its density.

    Evaluates ``noise_log_density`` on 4096 points spanning one period (periodic domain) or
    ``[-width, width]`` of the domain, and returns the square root of the second moment.

    Raises:
        ValueError: The density gives no finite positive scale.
    """
    domain = sensor.domain
    width = float(domain.high[0]) - float(domain.low[0])
    if domain.periodic[0]:
        residual = -0.5 * width + width * (np.arange(4096) + 0.5) / 4096
    else:
        residual = np.linspace(-width, width, 4097)
    log_density = np.asarray(
        sensor.noise_log_density(residual[:, None]),  # type: ignore[attr-defined]
        dtype=np.float64,
    )
    density = np.exp(log_density - np.max(log_density))
    density /= density.sum()
    std = float(np.sqrt(np.sum(density * residual**2)))
    if not (np.isfinite(std) and std > 0):
        raise ValueError(f"could not measure the noise scale of {sensor!r}")
    return std


def grid_points(sensor: Sensor, n_points: int | None = None) -> int:
    """Grid size of the FFT estimator for ``sensor`` (module docstring), or ``n_points``."""
    if n_points is not None:
        return int(n_points)
    domain = sensor.domain
    width = float(domain.high[0]) - float(domain.low[0])
    q = max(math.ceil(width * POINTS_PER_STD / noise_std(sensor)), MIN_POINTS)
    q = min(q, int(MAX_GRID_CELLS ** (1.0 / 3.0)))
    return int(scipy.fft.next_fast_len(q, real=True))


class NoiseKernel:
    """The discretised noise density on ``Q`` nodes, ready for FFT and windowed convolution.

    Attributes:
        periodic: Whether the observation wraps.
        low: Domain lower bound.
        n_points: ``Q``.
        spacing: Node spacing.
        length: FFT length (``Q`` periodic; ``Q`` plus the kernel support otherwise).
        spectrum: ``rfft`` of the circular kernel.
        entropy: Discrete entropy of the discretised noise density (``H(z | theta)`` per
            observation, up to ``log spacing``).
        window_half_width: Half width ``h`` (nodes) of the truncated kernel of windowed grids.
        window_taps: ``(2h + 1,)`` truncated kernel.
        window_matrices: Toeplitz matrices of the truncated kernel by window width (filled by
            :mod:`~infoseek.planners.information.windows` as windows are used).
    """

    def __init__(self, sensor: Sensor, n_points: int) -> None:
        domain = sensor.domain
        self.periodic = bool(domain.periodic[0])
        self.low = float(domain.low[0])
        self.n_points = n_points
        _, self.spacing = observation_nodes(domain, n_points)
        if self.periodic:
            offsets = np.arange(n_points)
            period = float(domain.high[0]) - self.low
            residual = (offsets * self.spacing + 0.5 * period) % period - 0.5 * period
        else:
            offsets = np.arange(-(n_points - 1), n_points)
            residual = offsets * self.spacing
        log_density = np.asarray(
            sensor.noise_log_density(residual[:, None]),  # type: ignore[attr-defined]
            dtype=np.float64,
        )
        if log_density.shape != offsets.shape or np.any(np.isnan(log_density)):
            raise ValueError("noise_log_density must return finite (or -inf) values of shape (...)")
        log_density = log_density - np.max(log_density)
        length = n_points
        if not self.periodic:
            support = np.abs(offsets[log_density > -60.0])
            half_width = int(support.max()) if support.size else 0
            keep = np.abs(offsets) <= half_width
            offsets, log_density = offsets[keep], log_density[keep]
            length = int(scipy.fft.next_fast_len(n_points + half_width, real=True))
        density = np.exp(log_density)
        density /= density.sum()
        self.entropy = float(entropy(density, (0,)))
        self._build_window(offsets, density)
        self.window_matrices: dict[int, NDArray[np.float32]] = {}
        circular = np.zeros(length)
        circular[offsets % length] = density
        self.length = length
        self.spectrum = scipy.fft.rfft(circular)
        self._full_spectrum = _full_spectrum(self.spectrum, length)

    def _build_window(self, offsets: NDArray[np.intp], density: FloatArray) -> None:
        """The kernel truncated to the smallest half width discarding < WINDOW_TAIL_MASS."""
        q = self.n_points
        signed = offsets - q * (offsets > q // 2) if self.periodic else offsets
        order = np.argsort(np.abs(signed), kind="stable")
        outside = 1.0 - np.cumsum(density[order])
        small = outside <= WINDOW_TAIL_MASS
        first = int(np.argmax(small)) if np.any(small) else order.size - 1
        self.window_half_width = int(np.abs(signed[order[first]]))
        taps = np.zeros(2 * self.window_half_width + 1)
        inside = np.abs(signed) <= self.window_half_width
        np.add.at(taps, signed[inside] + self.window_half_width, density[inside])
        self.window_taps = taps

    # -- assignment
    def positions(self, predictions: NDArray[Any], dtype: type = np.float64) -> NDArray[Any]:
        """Fractional node positions of predictions: in ``[0, Q)`` (periodic, wrapped) or
        ``[0, Q - 1]`` (clamped to the domain)."""
        position = np.asarray(predictions, dtype=dtype) - dtype(self.low)
        position *= dtype(1.0 / self.spacing)
        if self.periodic:
            # Predictions arrive wrapped into the domain; re-wrap only if some are not.
            if position.size and (position.min() < 0.0 or position.max() >= self.n_points):
                position %= dtype(self.n_points)
        else:
            np.clip(position, 0.0, self.n_points - 1.0, out=position)
        return position

    def assign(self, predictions: NDArray[Any]) -> tuple[NDArray[np.intp], FloatArray]:
        """Three-point quadratic assignment (module docstring).

        Args:
            predictions: ``(..., N)`` noise-free observations.

        Returns:
            ``(nearest (..., N), weights (..., N, 3))``: the nearest node ``j`` in ``[0, Q)``
            and the weights of nodes ``j - 1, j, j + 1``.
        """
        position = self.positions(predictions)
        nearest_float = np.floor(position + 0.5)
        delta = position - nearest_float
        nearest = nearest_float.astype(np.intp)
        if self.periodic:
            nearest[nearest >= self.n_points] -= self.n_points
        return nearest, stencil_weights(delta)

    def single_histograms(
        self, predictions: NDArray[Any], weights: FloatArray, uniform: bool
    ) -> FloatArray:
        """``(B, Q)`` stencil histograms of ``(B, N)`` predictions from three moment histograms
        (one compiled pass, :mod:`~infoseek.planners.information.moment_histograms`).

        Args:
            predictions: ``(B, N)`` noise-free observations (float32 is enough: the positions
                only need ~1e-7 of a node; other dtypes are rounded to float32).
            weights: ``(N,)`` normalised particle weights.
            uniform: Whether all weights are equal (unweighted mass histogram).
        """
        return single_stencil_histograms(
            np.asarray(predictions, dtype=np.float32),
            np.asarray(weights, dtype=np.float64),
            uniform,
            self.low,
            self.spacing,
            self.n_points,
            self.periodic,
        )

    def joint_histograms(
        self,
        assignments: Sequence[tuple[NDArray[np.intp], FloatArray]],
        particle_weights: FloatArray,
    ) -> FloatArray:
        """Full-grid stencil histograms ``(B, Q, ..., Q)`` of ``k`` joint observations (one
        ``numpy.bincount``; the pairs of the planners use the compiled
        :func:`~infoseek.planners.information.pair_histograms.full_grid_pair_histograms`).

        Args:
            assignments: ``k`` pairs ``(nearest (*batch, N), weights (*batch, N, 3))`` from
                :meth:`assign`; the batch shapes broadcast against each other.
            particle_weights: ``(N,)`` normalised particle weights.
        """
        k = len(assignments)
        q = self.n_points
        padded = q + 2  # one guard node each side takes the stencil's overhang
        batch = np.broadcast_shapes(*(idx.shape[:-1] for idx, _ in assignments))
        n_batch = int(np.prod(batch, dtype=np.int64))
        n = particle_weights.shape[0]
        cells = padded**k
        base = (np.arange(n_batch, dtype=np.intp) * cells).reshape(batch + (1,))
        stencil = np.zeros((1,), dtype=np.intp)
        weight = particle_weights
        for d, (idx, wts) in enumerate(assignments):
            stride = padded ** (k - 1 - d)
            base = base + idx * stride
            stencil = (stencil[..., None] + (np.arange(3) * stride)).reshape(-1)
            if d == 0:
                weight = wts * particle_weights[:, None]
            else:
                weight = (weight[..., :, None] * wts[..., None, :]).reshape(
                    np.broadcast_shapes(weight.shape[:-1], wts.shape[:-1]) + (-1,)
                )
        flat_index = base[..., None] + stencil
        flat_weight = np.broadcast_to(weight, batch + (n, 3**k))
        histogram = np.asarray(
            np.bincount(flat_index.ravel(), flat_weight.ravel(), minlength=n_batch * cells),
            dtype=np.float64,
        ).reshape((n_batch,) + (padded,) * k)
        # Fold the guard nodes back: across the seam (periodic) or onto the edge node.
        for d in range(1, k + 1):
            first: list[slice | int] = [slice(None)] * (k + 1)
            last: list[slice | int] = [slice(None)] * (k + 1)
            first[d], last[d] = 0, q + 1
            into_low: list[slice | int] = [slice(None)] * (k + 1)
            into_high: list[slice | int] = [slice(None)] * (k + 1)
            into_low[d], into_high[d] = 1, q
            if self.periodic:
                histogram[tuple(into_high)] += histogram[tuple(first)]
                histogram[tuple(into_low)] += histogram[tuple(last)]
            else:
                histogram[tuple(into_low)] += histogram[tuple(first)]
                histogram[tuple(into_high)] += histogram[tuple(last)]
        core = (slice(None),) + (slice(1, q + 1),) * k
        return histogram[core]

    # -- convolution
    def smoothed_entropy(self, histograms: NDArray[Any], dtype: type = np.float64) -> FloatArray:
        """Discrete entropy of histograms convolved with the noise density (FFT).

        Args:
            histograms: ``(B, Q, ..., Q)`` grid histograms of noise-free predictions (``k``
                grid axes after the batch axis).
            dtype: FFT precision (float32 halves the cost; ~1e-7 relative error).

        Returns:
            ``(B,)`` entropies (nats) of the normalised convolved grids.
        """
        q = self.n_points
        n_batch = histograms.shape[0]
        k = histograms.ndim - 1
        length = self.length
        grids: NDArray[Any]
        if length == q:
            grids = np.asarray(histograms, dtype=dtype)
        else:
            grids = np.zeros((n_batch,) + (length,) * k, dtype=dtype)
            grids[(slice(None),) + (slice(0, q),) * k] = histograms
        axes = tuple(range(1, k + 1))
        if k == 1:  # the one-dimensional transforms (the same pocketfft plans, less dispatch)
            spectrum = scipy.fft.rfft(grids, axis=1, workers=1)
            spectrum *= self.spectrum
            density = scipy.fft.irfft(spectrum, n=length, axis=1, workers=1)
        else:
            spectrum = scipy.fft.rfftn(grids, axes=axes, workers=1)
            if k == 2 and spectrum.dtype == np.complex128 and spectrum.flags.c_contiguous:
                # both products in one compiled pass
                filter_spectra(spectrum, self._full_spectrum, self.spectrum)
            else:
                for d in range(k):
                    shape = [1] * (k + 1)
                    shape[d + 1] = -1
                    spectrum *= (self.spectrum if d == k - 1 else self._full_spectrum).reshape(
                        shape
                    )
            density = scipy.fft.irfftn(spectrum, s=(length,) * k, axes=axes, workers=1)
        if length != q:
            density = density[(slice(None),) + (slice(0, q),) * k]
        if dtype is not np.float64:
            density = np.maximum(density.reshape(n_batch, -1), 0.0)
            density /= np.maximum(
                density.sum(axis=1, keepdims=True, dtype=np.float64), 1e-30
            ).astype(density.dtype)
            return entropy(density, (1,)).astype(np.float64)
        # clamp, normalise, clamp at 1e-300 and -sum p log p in two compiled passes around
        # NumPy's log (grid_entropy)
        rows = np.ascontiguousarray(density.reshape(n_batch, -1))
        normalise_rows(rows)
        return entropy_sums(rows, np.log(rows))


def stencil_weights(delta: NDArray[Any]) -> FloatArray:
    """``(..., 3)`` quadratic weights of nodes ``j - 1, j, j + 1`` for offsets ``delta``."""
    half_sq = 0.5 * delta * delta
    weights = np.empty(delta.shape + (3,), dtype=np.result_type(delta.dtype, np.float32))
    weights[..., 0] = half_sq - 0.5 * delta
    weights[..., 1] = 1.0 - 2.0 * half_sq
    weights[..., 2] = half_sq + 0.5 * delta
    return weights


def _full_spectrum(half: NDArray[np.complex128], length: int) -> NDArray[np.complex128]:
    """Full-length DFT of a real sequence from its ``rfft`` half."""
    tail = np.conj(half[1 : length - half.shape[0] + 1][::-1])
    return np.concatenate([half, tail])
