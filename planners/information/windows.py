r"""Pair MIs of an additive-noise sensor on windowed grids.

Once the belief has concentrated, each pose's predictions occupy a short interval of the
``Q``-node grid (:mod:`~infoseek.planners.information.noise_kernel`). Pose ``p`` then gets a
window of ``W_p`` nodes starting at integer node ``s_p``: periodic domains take the arc measured
from the first prediction, ``s_p = floor(x_1 + min_n wrap(x_n - x_1)) - 1`` (in node units; the
shortest arc whenever the predictions span less than half a period), window node ``j`` being
global node ``(s_p + j) mod Q``; non-periodic domains take ``s_p = max(min_n nearest_n - 1, 0)``
with the clamped stencil. As ``s_p`` is an integer, each stencil is exactly the full-grid
stencil relabelled. The pair histogram is ``H_ab = S_a^T diag(w) S_b`` (``S_p`` the ``N x W``
dense stencil matrix, float32; one matrix product per batch of pairs), and the noise
convolution is the *linear* one, ``D = K_a H_ab K_b^T`` with ``K`` the ``(W + 2h) x W``
Toeplitz matrix of the kernel truncated to ``|offset| <= h`` nodes, ``h`` the smallest half
width whose discarded noise mass is below ``1e-10``. Output node ``x`` of pose ``p`` is global
node ``s_p - h + x``; as long as ``W + 2h <= Q`` (periodic) these are distinct nodes, so ``D``
is the full-grid density restricted to them and the rest of the full grid carries only the
discarded tail. Non-periodic output nodes outside ``[0, Q)`` are zeroed, as the full grid drops
them. Entropies are invariant to the relabelling, so the windowed ``H(z_a, z_b)`` equals the
full-grid value up to the tail mass. Pose sets whose window does not fit use the full grid
(:func:`full_grid_pair_entropies`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.channels import BATCH_BUDGET
from infoseek.planners.information.grid_entropy import float32_grid_entropies
from infoseek.planners.information.noise_kernel import NoiseKernel
from infoseek.planners.information.pair_histograms import (
    full_grid_pair_histograms,
    windowed_scatter_histograms,
)
from infoseek.planners.information.window_stencils import pose_windows as compiled_pose_windows
from infoseek.planners.information.window_stencils import stencil_matrices

__all__ = ["WindowSide", "full_grid_pair_entropies", "pose_windows", "windowed_pair_entropies"]

_WINDOW_GEMM_CELLS = 24 * 24  # windowed pair histograms up to this size: matrix products
_WINDOW_SCATTER_ELEMENTS = 1 << 20  # stencil entries per chunk of the windowed scatter histogram
_FFT_CHUNK_CELLS = 1 << 18  # full-grid cells (Q^2 per pair) convolved per chunk


def pose_windows(
    kernel: NoiseKernel, predictions: NDArray[Any]
) -> tuple[NDArray[np.int64], NDArray[np.int32], NDArray[np.float32], NDArray[np.int64]]:
    """Windowed three-point stencils of each pose's predictions (see the module docstring;
    one compiled pass, :func:`~infoseek.planners.information.window_stencils.pose_windows`).

    Args:
        kernel: The noise kernel (grid of ``Q`` nodes, spacing ``h``).
        predictions: ``(P, N)`` noise-free observations of ``P`` poses (rounded to float32).

    Returns:
        ``(start (P,), targets (P, N, 3), weights (P, N, 3), width (P,))``: the global node
        of each pose's window origin, the window index of each stencil node (``0 <= targets <
        width``), the stencil weights (identical to :meth:`NoiseKernel.assign` up to float32)
        and the number of window nodes each pose needs.
    """
    return compiled_pose_windows(
        np.asarray(predictions, dtype=np.float32),
        kernel.low,
        kernel.spacing,
        kernel.n_points,
        kernel.periodic,
    )


def _convolution_matrix(kernel: NoiseKernel, width: int) -> NDArray[np.float32]:
    """``(width + 2 hw, width)`` float32 Toeplitz matrix of the truncated noise kernel (linear
    convolution), built once per width and kept by the kernel."""
    matrix = kernel.window_matrices.get(width)
    if matrix is None:
        half = kernel.window_half_width
        lag = np.arange(width + 2 * half)[:, None] - np.arange(width)[None, :]
        inside = (lag >= 0) & (lag <= 2 * half)
        matrix = np.where(inside, kernel.window_taps[np.clip(lag, 0, 2 * half)], 0.0)
        matrix = matrix.astype(np.float32)
        kernel.window_matrices[width] = matrix
    return matrix


class WindowSide:
    """One side of a batch of pairs: windowed stencils of ``P`` poses (see :func:`pose_windows`).

    Args:
        kernel: The noise kernel.
        start, widths: ``(P,)`` window origin and size of each pose of the side.
        targets, weights: ``(R, N, 3)`` window stencils, as returned by :func:`pose_windows`;
            the side's poses are their ``rows`` (a side of a pose set reads the stencils a
            belief keeps for every pose it has seen, in place).
        rows: ``(P,)`` rows of ``targets`` and ``weights`` (``None``: ``R = P``, all of them).

    Attributes:
        width: Common window size (the largest of ``widths``).
        size: ``P``.
        out: Output nodes per axis after the linear convolution (``width + 2h``).
        fits: Whether the window plus the kernel support fits in one period (always true on a
            non-periodic domain).
        mask: Non-periodic domains: ``(P, out)`` 1 where an output node lies in the domain.
    """

    def __init__(
        self,
        kernel: NoiseKernel,
        start: NDArray[np.int64],
        targets: NDArray[np.int32],
        weights: NDArray[np.float32],
        widths: NDArray[np.int64],
        rows: NDArray[np.int64] | None = None,
    ) -> None:
        self.start, self.targets, self.weights, self.widths = start, targets, weights, widths
        self.rows = np.arange(targets.shape[0], dtype=np.int64) if rows is None else rows
        self.width = int(self.widths.max())
        self.size = int(self.rows.shape[0])
        self.out = self.width + 2 * kernel.window_half_width
        self.fits = not kernel.periodic or self.out <= kernel.n_points
        self._stencils: NDArray[np.float32] | None = None
        self.mask: FloatArray | None = None
        if not kernel.periodic:  # the full grid keeps only the domain's nodes
            nodes = self.start[:, None] - kernel.window_half_width + np.arange(self.out)
            self.mask = ((nodes >= 0) & (nodes < kernel.n_points)).astype(np.float64)

    @property
    def nbytes(self) -> int:
        """Memory held by the side itself (the dense stencils, as far as built)."""
        return 0 if self._stencils is None else int(self._stencils.nbytes)

    @classmethod
    def from_predictions(cls, kernel: NoiseKernel, predictions: NDArray[Any]) -> WindowSide:
        """The side of ``(P, N)`` predictions."""
        start, targets, weights, widths = pose_windows(kernel, predictions)
        return cls(kernel, start, targets, weights, widths)

    def stencils(self) -> NDArray[np.float32]:
        """Dense ``(P W, N)`` float32 stencil matrices
        (:func:`~infoseek.planners.information.window_stencils.stencil_matrices`), built once."""
        if self._stencils is None:
            self._stencils = stencil_matrices(self.targets, self.weights, self.width, self.rows)
        return self._stencils


def windowed_pair_entropies(
    kernel: NoiseKernel,
    side_a: WindowSide,
    side_b: WindowSide,
    particle_weights: FloatArray,
    uniform: bool | None = None,
) -> FloatArray:
    """Discrete joint entropies ``H(z_a, z_b)`` ``(C, M)`` on windowed grids.

    Both sides must fit (:attr:`WindowSide.fits`); the result equals the full-grid entropy up
    to the discarded kernel tail (module docstring). ``uniform``: whether all particle weights
    are equal (``None``: compared here).
    """
    width_a, width_b = side_a.width, side_b.width
    n_a, n_b = side_a.size, side_b.size
    n = particle_weights.shape[0]
    out_a, out_b = side_a.out, side_b.out
    conv_a = _convolution_matrix(kernel, width_a)  # (out_a, width_a)
    conv_b = conv_a if width_b == width_a else _convolution_matrix(kernel, width_b)
    gemm = width_a * width_b <= _WINDOW_GEMM_CELLS
    if gemm:
        if uniform is None:
            uniform = bool(particle_weights.min() == particle_weights.max())
        stencil_a = side_a.stencils()
        if not uniform:
            stencil_a = stencil_a * particle_weights.astype(np.float32)
        stencil_b = side_b.stencils()
    cells = max(width_a * width_b, out_a * out_b)
    chunk = max(1, BATCH_BUDGET // (4 * n_b * cells))
    if not gemm:
        chunk = min(chunk, max(1, _WINDOW_SCATTER_ELEMENTS // (9 * n_b * n)))
    joint = np.empty((n_a, n_b))
    for begin in range(0, n_a, chunk):
        end = min(begin + chunk, n_a)
        size = end - begin
        if gemm:
            left = stencil_a[begin * width_a : end * width_a]
            histogram = left @ stencil_b.T  # one float32 matrix product for the whole batch
            if uniform:
                histogram *= np.float32(particle_weights[0])
            histogram = histogram.reshape(size, width_a, n_b, width_b).transpose(0, 2, 1, 3)
        else:
            histogram = windowed_scatter_histograms(
                side_a.targets,
                side_a.weights,
                side_b.targets,
                side_b.weights,
                particle_weights,
                width_a,
                width_b,
                side_a.rows[begin:end],
                side_b.rows,
            )
        mask_a = None if side_a.mask is None else side_a.mask[begin:end]
        joint[begin:end] = _smoothed_entropies(histogram, conv_a, conv_b, mask_a, side_b.mask)
    return joint


def _smoothed_entropies(
    histogram: NDArray[np.float32],
    conv_a: NDArray[np.float32],
    conv_b: NDArray[np.float32],
    mask_a: FloatArray | None,
    mask_b: FloatArray | None,
) -> FloatArray:
    """``(C, M)`` entropies of ``(C, M, W_a, W_b)`` window histograms convolved with the noise.

    The linear convolution along both axes, ``conv_a H conv_b^T`` (axes ``(c, m, out_b,
    out_a)``), is two float32 matrix products (probabilities to ~1e-7: far below any planning
    or test tolerance); non-periodic grids zero the output nodes outside the domain; the grids
    are clamped at ``1e-38``, normalised and turned into ``-sum p log p`` by compiled passes
    around NumPy's float32 log (:func:`~infoseek.planners.information.grid_entropy.
    float32_grid_entropies`).
    """
    size, n_b = histogram.shape[:2]
    smoothed = np.matmul(histogram, conv_b.T)  # (size, n_b, width_a, out_b)
    density = np.matmul(smoothed.transpose(0, 1, 3, 2), conv_a.T)  # (.., out_b, out_a)
    if mask_a is not None and mask_b is not None:
        density *= mask_a[:, None, None, :]
        density *= mask_b[None, :, :, None]
    rows = np.ascontiguousarray(density.reshape(size * n_b, -1))
    return float32_grid_entropies(rows).reshape(size, n_b)


def full_grid_pair_entropies(
    kernel: NoiseKernel,
    predictions_a: NDArray[Any],
    predictions_b: NDArray[Any],
    weights: FloatArray,
) -> FloatArray:
    """``(C, M)`` discrete joint entropies ``H(z_a, z_b)`` on the full ``Q x Q`` grid.

    The histograms of a chunk of pairs come from one compiled pass
    (:func:`~infoseek.planners.information.pair_histograms.full_grid_pair_histograms`), the
    noise convolution and the entropies from :meth:`NoiseKernel.smoothed_entropy`.

    Args:
        kernel: The noise kernel.
        predictions_a: ``(C, N)`` predictions of one side (float32, or float64).
        predictions_b: ``(M, N)`` predictions of the other side (the dtype of ``a``).
        weights: ``(N,)`` normalised particle weights.
    """
    n_a, n_b = predictions_a.shape[0], predictions_b.shape[0]
    result = np.empty((n_a, n_b))
    chunk = max(1, _FFT_CHUNK_CELLS // (n_b * kernel.length**2))
    for start in range(0, n_a, chunk):
        stop = min(start + chunk, n_a)
        histograms = full_grid_pair_histograms(
            predictions_a[start:stop],
            predictions_b,
            weights,
            kernel.low,
            kernel.spacing,
            kernel.n_points,
            kernel.periodic,
        )
        flat = histograms.reshape((-1,) + histograms.shape[2:])
        result[start:stop] = kernel.smoothed_entropy(flat).reshape(stop - start, n_b)
    return result
