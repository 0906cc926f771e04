"""The sensor model interface (eq. 3 of Hoffmann, Waslander & Tomlin 2006).

A sensor model is the a-priori measurement model ``z = h(x, theta, eta)`` shared by every
vehicle. infoseek needs two things from it:

* ``sample`` draws observations, used by the environment (with the true target) and by Monte
  Carlo estimators of mutual information (with particles as hypothetical targets);
* ``log_likelihood`` evaluates ``log p(z | theta)`` for every particle, used by the particle
  filter (eq. 11-12) and by the quadrature of eq. 16 and 19.

Both broadcast over leading batch dimensions so that one call serves a whole batch of agents,
candidate controls and quadrature nodes:

* ``poses``: ``(..., pose_dim)`` sensor poses (for every model shipped here, the planar
  position ``(x, y)`` of the vehicle carrying the sensor);
* ``z``: ``(..., obs_dim)`` observations; the batch shapes of ``z`` and ``poses`` broadcast
  against each other;
* ``particles``: ``(N, target_dim)`` target hypotheses; the result has shape ``(..., N)``.

The observation domain (:class:`ObservationDomain`) tells quadrature where ``z`` lives and
which coordinates are periodic angles.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ObservationDomain:
    """Where a sensor's observations live.

    Attributes:
        low: ``(obs_dim,)`` lower bound of each observation coordinate.
        high: ``(obs_dim,)`` upper bound of each observation coordinate.
        periodic: ``(obs_dim,)`` whether the coordinate is an angle that wraps from ``high``
            back to ``low`` (the period is ``high - low``). A non-periodic coordinate's bounds
            are chosen wide enough that the likelihood mass outside them is negligible for
            every pose/target pair in the search domain (documented per sensor).
    """

    low: tuple[float, ...]
    high: tuple[float, ...]
    periodic: tuple[bool, ...]

    def __post_init__(self) -> None:
        if not (len(self.low) == len(self.high) == len(self.periodic)):
            raise ValueError(
                "ObservationDomain: low, high and periodic must have the same length, got "
                f"{len(self.low)}, {len(self.high)} and {len(self.periodic)}"
            )
        for i, (lo, hi) in enumerate(zip(self.low, self.high, strict=True)):
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise ValueError(
                    f"ObservationDomain: coordinate {i} needs finite low < high, got [{lo}, {hi}]"
                )

    @property
    def dim(self) -> int:
        """Number of observation coordinates ``obs_dim``."""
        return len(self.low)

    @property
    def size(self) -> float:
        """Lebesgue measure of the domain (product of widths); ``log(size)`` bounds H(z)."""
        return float(np.prod(np.subtract(self.high, self.low)))


@runtime_checkable
class Sensor(Protocol):
    """A measurement model ``z = h(x, theta, eta)`` (eq. 3).

    Attributes:
        name: Short registry name (``"bearing"``, ``"beacon"``, ``"range"``).
        pose_dim: Length of a sensor pose (2 for a planar position).
        target_dim: Length of a target state ``theta``.
        obs_dim: Length of an observation ``z``.
        domain: The observation domain, for quadrature.
    """

    name: str
    pose_dim: int
    target_dim: int
    obs_dim: int
    domain: ObservationDomain

    def sample(
        self, poses: FloatArray, targets: FloatArray, rng: np.random.Generator
    ) -> FloatArray:
        """Draw observations.

        Args:
            poses: ``(..., pose_dim)`` sensor poses.
            targets: ``(..., target_dim)`` target states; broadcasts against ``poses``.
            rng: Source of the observation noise.

        Returns:
            ``(..., obs_dim)`` observations inside :attr:`domain` (angles wrapped).
        """
        ...

    def log_likelihood(self, z: FloatArray, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """``log p(z | theta)`` for every particle.

        Args:
            z: ``(..., obs_dim)`` observations.
            poses: ``(..., pose_dim)`` sensor poses; batch shape broadcasts against ``z``.
            particles: ``(N, target_dim)`` target hypotheses.

        Returns:
            ``(..., N)`` log densities with respect to Lebesgue measure on :attr:`domain`
            (finite or ``-inf``; never NaN for finite inputs).
        """
        ...


@runtime_checkable
class AdditiveNoiseSensor(Sensor, Protocol):
    """A sensor whose observation is a noise-free prediction plus independent additive noise.

    ``z = wrap(predict(pose, theta) + eta)`` with ``eta`` drawn from a fixed density that does not
    depend on the pose or the target. This structure lets mutual information be computed by
    binning predictions and convolving with the noise density (the planners' fast path).
    """

    def predict(self, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """Noise-free observations.

        Args:
            poses: ``(..., pose_dim)`` sensor poses.
            particles: ``(N, target_dim)`` target hypotheses.

        Returns:
            ``(..., N, obs_dim)`` noise-free observations (angles wrapped into the domain).
        """
        ...

    def noise_log_density(self, residual: FloatArray) -> FloatArray:
        """Log density of the additive noise.

        Args:
            residual: ``(..., obs_dim)`` values of ``z - predict`` (for periodic coordinates,
                wrapped to a centred interval of one period).

        Returns:
            ``(...)`` log densities (for periodic coordinates, of the wrapped noise).
        """
        ...


@runtime_checkable
class ShiftKernelSensor(Sensor, Protocol):
    """A sensor whose likelihood is a shifted member of a one-parameter kernel family.

    ``p(z | theta) = f_s(wrap(z - c))`` on a periodic one-dimensional observation, with centre
    ``c`` and shape ``s`` functions of the pose and the target. The beacon receiver is one
    (``c`` the field-line angle, ``s`` the signal-to-noise ratio); an additive-noise sensor is
    the special case of a single kernel. The structure lets mutual information be computed
    from tabulated Fourier coefficients of ``f_s`` (the planners' ``"fourier"`` estimator).

    Attributes:
        max_kernel_shape: The largest value ``s`` can take (``inf`` if unbounded).
    """

    max_kernel_shape: float

    def kernel_parameters(
        self, poses: FloatArray, particles: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """``(centre, shape)``, each ``(..., N)``, for poses ``(..., pose_dim)``."""
        ...

    def kernel_log_density(self, residual: FloatArray, shape: FloatArray) -> FloatArray:
        """``log f_shape(residual)`` for broadcasting ``residual`` and ``shape`` arrays."""
        ...
