"""The ``fourier`` estimator's per-belief work: kernel spectra and channels of every pose seen.

One :class:`FourierCache` belongs to one :class:`~infoseek.planners.information.base.BeliefMI`
(it lives in the belief's cache). Spectra ``(Q // 2 + 1, N)`` complex64 and channels
``(Q, N)`` float32 of every pose asked for are kept by two
:class:`~infoseek.planners.information.pose_rows.PoseRows`, each with the pose's conditional
entropy ``H(z | theta) = sum_n w_n h(s_n)``. Poses computed together stay together, so the
pose sets of a planner (a vehicle's candidates) are views, not copies; other sets are
gathered. Each pose is computed exactly as alone, so the values do not depend on what
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

__all__ = ["FourierCache"]


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
        spectra = self._spectra.take("spectra", rows)
        return spectra, self._spectra.take("conditional", rows)  # type: ignore[return-value]

    def _compute_channels(self, poses: FloatArray) -> dict[str, NDArray[Any]]:
        spectra, conditional = self.spectra(poses)
        channels = scipy.fft.irfft(spectra, n=self.estimator.n_points, axis=1)  # float32
        return {"channels": channels, "conditional": conditional}

    def channels(self, poses: FloatArray) -> tuple[NDArray[np.float32], FloatArray]:
        """``(P, Q, N)`` float32 channels and ``(P,)`` conditional entropies of ``poses``."""
        rows = self._channels.lookup(poses, self._compute_channels)
        channels = self._channels.take("channels", rows)
        return channels, self._channels.take("conditional", rows)  # type: ignore[return-value]
