"""The ``fourier`` estimator's per-belief work: kernel spectra and channels of every pose seen.

One :class:`FourierCache` belongs to one :class:`~infoseek.planners.information.base.BeliefMI`
(it lives in the belief's cache). Spectra ``(Q // 2 + 1, N)`` complex64 and channels
``(Q, N)`` float32 of every pose asked for are rows of two
:class:`~infoseek.planners.information.pose_rows.PoseRows`, each with the pose's conditional
entropy ``H(z | theta) = sum_n w_n h(s_n)``. Poses computed together are consecutive rows, so
the pose sets of a planner (a vehicle's candidates) are views of the banks, not copies; other
sets are gathered. Each pose is computed exactly as alone, so the values do not depend on what
was cached before.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.fft
from numpy.typing import NDArray

from infoseek.planners.information.base import CACHE_BYTES, BeliefMI, FloatArray
from infoseek.planners.information.pose_rows import PoseRows

if TYPE_CHECKING:
    from infoseek.planners.information.fourier import ShiftKernelEstimator

__all__ = ["FourierCache", "rows_block"]


def rows_block(bank: NDArray[Any], rows: NDArray[np.int64]) -> NDArray[Any]:
    """``bank[rows]``: a view when the rows are consecutive, else a gathered copy."""
    if rows.shape[0] and rows[-1] - rows[0] + 1 == rows.shape[0]:
        if rows.shape[0] == 1 or bool(np.all(np.diff(rows) == 1)):
            return bank[int(rows[0]) : int(rows[-1]) + 1]
    return bank[rows]


class FourierCache:
    """Spectra and channels of one belief (module docstring).

    Args:
        estimator: The ``fourier`` estimator.
        belief: The bound belief.
    """

    def __init__(self, estimator: ShiftKernelEstimator, belief: BeliefMI) -> None:
        self.estimator = estimator
        self.belief = belief
        self._spectra = PoseRows(CACHE_BYTES // 2)
        self._channels = PoseRows(CACHE_BYTES // 2)

    @property
    def nbytes(self) -> int:
        """Bytes held."""
        return self._spectra.nbytes + self._channels.nbytes

    def _compute_spectra(self, poses: FloatArray) -> dict[str, NDArray[Any]]:
        spectra, h = self.estimator._spectra(poses, self.belief)
        return {"spectra": spectra, "conditional": h @ self.belief.weights}

    def spectra(self, poses: FloatArray) -> tuple[NDArray[np.complex64], FloatArray]:
        """``(X (P, Q // 2 + 1, N), conditional (P,))`` of ``poses``."""
        rows = self._spectra.lookup(poses, self._compute_spectra)
        spectra = rows_block(self._spectra.bank("spectra"), rows)
        return spectra, self._spectra.bank("conditional")[rows]  # type: ignore[return-value]

    def _compute_channels(self, poses: FloatArray) -> dict[str, NDArray[Any]]:
        spectra, conditional = self.spectra(poses)
        channels = scipy.fft.irfft(spectra, n=self.estimator.n_points, axis=1)  # float32
        return {"channels": channels, "conditional": conditional}

    def channels(self, poses: FloatArray) -> tuple[NDArray[np.float32], FloatArray]:
        """``(P, Q, N)`` float32 channels and ``(P,)`` conditional entropies of ``poses``."""
        rows = self._channels.lookup(poses, self._compute_channels)
        channels = rows_block(self._channels.bank("channels"), rows)
        return channels, self._channels.bank("conditional")[rows]  # type: ignore[return-value]
