"""Target state space, target motion and the prior ``p_0`` (section II.A of Hoffmann et al. 2006).

The target state ``theta`` lives in a box ``Theta = prod_j [low_j, high_j]``. The first two
coordinates are always the planar position ``(x, y)``; further coordinates are angles such as
the beacon orientation ``psi_a`` of section IV.B. An angle coordinate is *periodic*: it wraps
from ``high`` back to ``low`` (period ``P = high - low``). An angle may further be *axial*: the
observations only identify it modulo ``P / 2`` (a dipole and its reversal produce the same field
lines), so its MMSE estimate is the axial mean (circular mean of the doubled angles, halved).

The prior ``p_0`` is uniform over ``Theta`` (section IV: "The prior distribution is uniform over
the domain"), drawn by :meth:`TargetSpace.sample_uniform`.

Target motion models propagate target hypotheses (particles) over one time step ``dt``:

* :class:`StationaryTarget` -- ``theta_{t+1} = theta_t`` (the paper's targets);
* :class:`RandomWalkTarget` -- ``theta_{t+1} = theta_t + sqrt(dt) * eps``, ``eps ~ N(0, diag(s^2))``
  with ``s = position_std`` for position coordinates and ``s = angle_std`` for angles; positions
  are reflected back into the box, angles wrapped.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.registries import Registry

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = [
    "TARGET_MOTION_REGISTRY",
    "RandomWalkTarget",
    "StationaryTarget",
    "TargetMotion",
    "TargetSpace",
    "make_target_motion",
    "reflect_into_interval",
]


def _check_rng(rng: object, name: str = "rng") -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"{name} must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def reflect_into_interval(values: FloatArray, low: FloatArray, high: FloatArray) -> FloatArray:
    """Fold values back into ``[low, high]`` by mirror reflection at the walls.

    Args:
        values: ``(..., k)`` values.
        low: ``(k,)`` lower walls.
        high: ``(k,)`` upper walls (``high > low``).

    Returns:
        ``(..., k)`` reflected values, each inside ``[low, high]``.
    """
    width = high - low
    folded = np.mod(values - low, 2.0 * width)
    folded = np.where(folded > width, 2.0 * width - folded, folded)
    return np.clip(low + folded, low, high)


@dataclass(frozen=True)
class TargetSpace:
    """The target state space ``Theta`` (a box, some coordinates periodic angles).

    Attributes:
        low: ``(d,)`` lower bound of every coordinate.
        high: ``(d,)`` upper bound of every coordinate (``high > low``).
        periodic: ``(d,)`` whether the coordinate is an angle wrapping into ``[low, high)``
            (period ``high - low``). The two position coordinates must not be periodic.
        axial: ``(d,)`` whether the (periodic) angle is only identifiable modulo half its
            period; its MMSE estimate is the axial mean (mean of doubled angles, halved).
        names: ``(d,)`` coordinate names (for observation manuals and plots).
    """

    low: tuple[float, ...]
    high: tuple[float, ...]
    periodic: tuple[bool, ...]
    axial: tuple[bool, ...]
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        lengths = {
            "low": len(self.low),
            "high": len(self.high),
            "periodic": len(self.periodic),
            "axial": len(self.axial),
            "names": len(self.names),
        }
        if len(set(lengths.values())) != 1:
            raise ValueError(
                f"TargetSpace: low, high, periodic, axial, names differ in length: {lengths}"
            )
        if len(self.low) < 2:
            raise ValueError(
                f"TargetSpace: needs at least the 2 position coordinates, got dim {len(self.low)}"
            )
        for j, (lo, hi) in enumerate(zip(self.low, self.high, strict=True)):
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise ValueError(
                    f"TargetSpace: coordinate {j} ({self.names[j]!r}) needs finite low < high, "
                    f"got [{lo}, {hi}]"
                )
        for j in self.position_dims:
            if self.periodic[j]:
                raise ValueError(
                    f"TargetSpace: position coordinate {j} ({self.names[j]!r}) cannot be periodic"
                )
        for j, (per, ax) in enumerate(zip(self.periodic, self.axial, strict=True)):
            if ax and not per:
                raise ValueError(
                    f"TargetSpace: coordinate {j} ({self.names[j]!r}) is axial but not periodic"
                )

    @property
    def dim(self) -> int:
        """Number of target coordinates ``d``."""
        return len(self.low)

    @property
    def position_dims(self) -> tuple[int, int]:
        """Indices of the planar position coordinates (always ``(0, 1)``)."""
        return (0, 1)

    @property
    def low_array(self) -> FloatArray:
        """``(d,)`` lower bounds as an array."""
        return np.asarray(self.low, dtype=np.float64)

    @property
    def high_array(self) -> FloatArray:
        """``(d,)`` upper bounds as an array."""
        return np.asarray(self.high, dtype=np.float64)

    @property
    def periodic_mask(self) -> BoolArray:
        """``(d,)`` boolean mask of periodic coordinates."""
        return np.asarray(self.periodic, dtype=bool)

    @property
    def axial_mask(self) -> BoolArray:
        """``(d,)`` boolean mask of axial coordinates."""
        return np.asarray(self.axial, dtype=bool)

    @property
    def volume(self) -> float:
        """Lebesgue measure of ``Theta`` (product of the widths)."""
        return float(np.prod(self.high_array - self.low_array))

    def _check_states(self, states: object, name: str = "states") -> FloatArray:
        arr = np.asarray(states, dtype=np.float64)
        if arr.ndim < 1 or arr.shape[-1] != self.dim:
            raise ValueError(f"{name} must have shape (..., {self.dim}), got {arr.shape}")
        return arr

    def sample_uniform(self, n: int, rng: np.random.Generator) -> FloatArray:
        """Draw ``n`` samples from the uniform prior ``p_0`` over ``Theta``.

        Args:
            n: Number of samples (``>= 0``).
            rng: Random generator.

        Returns:
            ``(n, d)`` samples (periodic coordinates in ``[low, high)``).
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
            raise ValueError(f"n must be a non-negative integer, got {n!r}")
        _check_rng(rng)
        low, high = self.low_array, self.high_array
        return low + (high - low) * rng.random((int(n), self.dim))

    def wrap(self, states: FloatArray) -> FloatArray:
        """Wrap periodic coordinates into ``[low, high)``; other coordinates are unchanged.

        Args:
            states: ``(..., d)`` states.

        Returns:
            ``(..., d)`` new array.
        """
        arr = self._check_states(states).copy()
        mask = self.periodic_mask
        if mask.any():
            low = self.low_array[mask]
            period = self.high_array[mask] - low
            wrapped = np.mod(arr[..., mask] - low, period)
            wrapped = np.where(wrapped >= period, 0.0, wrapped)  # mod can round up to period
            arr[..., mask] = low + wrapped
        return arr

    def contains(self, states: FloatArray) -> BoolArray:
        """Whether each state lies in ``Theta`` (periodic coordinates need only be finite).

        Args:
            states: ``(..., d)`` states.

        Returns:
            ``(...)`` boolean array.
        """
        arr = self._check_states(states)
        inside = (arr >= self.low_array) & (arr <= self.high_array)
        inside = inside | (self.periodic_mask & np.isfinite(arr))
        return np.all(inside, axis=-1)

    @classmethod
    def planar(cls, size: tuple[float, float] = (40.0, 40.0)) -> TargetSpace:
        """The position-only space ``[0, size_x] x [0, size_y]`` (bearings-only search, IV.A)."""
        sx, sy = _check_size(size)
        return cls(
            low=(0.0, 0.0),
            high=(sx, sy),
            periodic=(False, False),
            axial=(False, False),
            names=("x", "y"),
        )

    @classmethod
    def planar_with_orientation(cls, size: tuple[float, float] = (40.0, 40.0)) -> TargetSpace:
        """Position plus an axial orientation ``psi in [0, 2 pi)`` (rescue beacon, IV.B)."""
        sx, sy = _check_size(size)
        return cls(
            low=(0.0, 0.0, 0.0),
            high=(sx, sy, 2.0 * np.pi),
            periodic=(False, False, True),
            axial=(False, False, True),
            names=("x", "y", "psi"),
        )


def _check_size(size: object) -> tuple[float, float]:
    try:
        sx, sy = (float(s) for s in size)  # type: ignore[attr-defined]
    except (TypeError, ValueError) as err:
        raise ValueError(f"size must be a pair of positive floats, got {size!r}") from err
    if not (np.isfinite(sx) and np.isfinite(sy) and sx > 0 and sy > 0):
        raise ValueError(f"size must be a pair of positive finite floats, got {size!r}")
    return sx, sy


@runtime_checkable
class TargetMotion(Protocol):
    """A target motion model ``theta_{t+1} ~ p(theta_{t+1} | theta_t)``.

    Attributes:
        name: Short registry name.
    """

    name: str

    def propagate(
        self, states: FloatArray, space: TargetSpace, dt: float, rng: np.random.Generator
    ) -> FloatArray:
        """Advance target hypotheses by ``dt``.

        Args:
            states: ``(N, d)`` target states.
            space: The target space (for walls and wrapping).
            dt: Time step (``> 0``).
            rng: Source of process noise.

        Returns:
            ``(N, d)`` new array of propagated states inside ``space``.
        """
        ...


class StationaryTarget:
    """A target that does not move: ``propagate`` returns a copy (no process noise)."""

    name = "stationary"

    def propagate(
        self, states: FloatArray, space: TargetSpace, dt: float, rng: np.random.Generator
    ) -> FloatArray:
        """Return a copy of ``(N, d)`` ``states`` unchanged."""
        return np.array(states, dtype=np.float64, copy=True)

    def __repr__(self) -> str:
        return "StationaryTarget()"


class RandomWalkTarget:
    """Gaussian random walk: ``theta' = theta + sqrt(dt) eps``, ``eps ~ N(0, diag(s^2))``.

    ``s_j = position_std`` for non-periodic coordinates (reflected at the box walls) and
    ``s_j = angle_std`` for periodic angles (wrapped).

    Args:
        position_std: Standard deviation per unit time of the position increments (``>= 0``).
        angle_std: Standard deviation per unit time of the angle increments (``>= 0``).
    """

    name = "random_walk"

    def __init__(self, position_std: float = 0.1, angle_std: float = 0.0) -> None:
        for label, value in (("position_std", position_std), ("angle_std", angle_std)):
            if not (isinstance(value, int | float | np.floating) and np.isfinite(value)):
                raise ValueError(f"{label} must be a finite float >= 0, got {value!r}")
            if value < 0:
                raise ValueError(f"{label} must be >= 0, got {value!r}")
        self.position_std = float(position_std)
        self.angle_std = float(angle_std)

    def propagate(
        self, states: FloatArray, space: TargetSpace, dt: float, rng: np.random.Generator
    ) -> FloatArray:
        """Random-walk ``(N, d)`` states over ``dt``; see the class docstring."""
        _check_rng(rng)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite float, got {dt!r}")
        arr = space._check_states(states)
        periodic = space.periodic_mask
        std = np.where(periodic, self.angle_std, self.position_std) * np.sqrt(dt)
        moved = arr + std * rng.standard_normal(arr.shape)
        linear = ~periodic
        moved[..., linear] = reflect_into_interval(
            moved[..., linear], space.low_array[linear], space.high_array[linear]
        )
        return space.wrap(moved)

    def __repr__(self) -> str:
        return f"RandomWalkTarget(position_std={self.position_std}, angle_std={self.angle_std})"


#: Registry name -> target motion class.
TARGET_MOTION_REGISTRY: Registry[Callable[..., TargetMotion]] = Registry(
    "target motion", TargetMotion
)
TARGET_MOTION_REGISTRY.register("stationary", StationaryTarget)
TARGET_MOTION_REGISTRY.register("random_walk", RandomWalkTarget)


def make_target_motion(spec: str | TargetMotion, **kwargs: Any) -> TargetMotion:
    """Build a target motion model from a registry name or pass an instance through.

    Args:
        spec: A key of :data:`TARGET_MOTION_REGISTRY` or a :class:`TargetMotion` instance.
        **kwargs: Constructor arguments (only with a registry name).

    Returns:
        The motion model.

    Raises:
        TypeError: ``kwargs`` given with an instance, or ``spec`` of the wrong type.
        ValueError: Unknown registry name.
    """
    return TARGET_MOTION_REGISTRY.make(spec, **kwargs)
