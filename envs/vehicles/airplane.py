"""Fixed-speed airplane (unicycle) model for the bearings-only search of section IV.A.

State ``x = (x, y, heading)``, control ``u = (turn_rate,)`` with ``|u| <= max_turn_rate``.
Within one time step ``dt`` the turn rate is held constant, so the airplane flies an arc of a
circle of radius ``speed / |u|`` (eq. 1 with exact integration):

    heading' = heading + u dt
    (x', y') = (x, y) + speed dt sinc(u dt / 2) (cos(heading + u dt / 2), sin(heading + u dt / 2))

where ``sinc(a) = sin(a) / a``: the chord of the arc has length ``2 (speed / u) sin(u dt / 2)``
and points along the mean heading. The formula is smooth at ``u = 0`` (straight flight), so
no special case is needed. Headings are wrapped into ``[-pi, pi)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["Airplane", "check_positive", "prepare_step_inputs"]


def check_positive(value: object, name: str) -> float:
    """Return ``value`` as a float, or raise ValueError naming ``name`` unless finite and > 0."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a positive finite float, got {type(value).__name__}")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite float, got {value!r}")
    return float(value)


def prepare_step_inputs(
    states: object,
    controls: object,
    dt: object,
    state_dim: int,
    control_dim: int,
    low: FloatArray,
    high: FloatArray,
) -> tuple[FloatArray, FloatArray, float]:
    """Validate and broadcast ``step`` inputs.

    Args:
        states: ``(..., state_dim)`` states.
        controls: ``(..., control_dim)`` controls; batch shape broadcasts against ``states``.
        dt: Time step (positive, finite).
        state_dim: Expected state length.
        control_dim: Expected control length.
        low: ``(control_dim,)`` lower control bounds.
        high: ``(control_dim,)`` upper control bounds.

    Returns:
        Broadcast ``(B..., state_dim)`` states, ``(B..., control_dim)`` controls clipped into
        ``[low, high]``, and ``dt`` as a float.
    """
    dt_f = check_positive(dt, "dt")
    s = np.asarray(states, dtype=np.float64)
    c = np.asarray(controls, dtype=np.float64)
    if s.ndim < 1 or s.shape[-1] != state_dim:
        raise ValueError(f"states must have shape (..., {state_dim}), got {s.shape}")
    if c.ndim < 1 or c.shape[-1] != control_dim:
        raise ValueError(f"controls must have shape (..., {control_dim}), got {c.shape}")
    if not np.all(np.isfinite(s)):
        raise ValueError("states must be finite (got NaN or inf)")
    if not np.all(np.isfinite(c)):
        raise ValueError("controls must be finite (got NaN or inf)")
    try:
        batch = np.broadcast_shapes(s.shape[:-1], c.shape[:-1])
    except ValueError as err:
        raise ValueError(
            f"states batch shape {s.shape[:-1]} and controls batch shape {c.shape[:-1]} "
            "do not broadcast"
        ) from err
    s = np.broadcast_to(s, (*batch, state_dim))
    c = np.clip(np.broadcast_to(c, (*batch, control_dim)), low, high)
    return s, c, dt_f


def _readonly(values: FloatArray) -> FloatArray:
    arr = np.array(values, dtype=np.float64)
    arr.flags.writeable = False
    return arr


class Airplane:
    """Fixed-speed airplane with a limited turn rate (unicycle, exact arc integration).

    Args:
        speed: Constant forward speed (> 0, units per second).
        max_turn_rate: Turn-rate limit (> 0, rad/s); control bounds are ``+-max_turn_rate``.

    Attributes:
        name: ``"airplane"``.
        state_dim: 3, ``(x, y, heading)``.
        control_dim: 1, ``(turn_rate,)``.
        control_low: ``(1,)`` read-only ``[-max_turn_rate]``.
        control_high: ``(1,)`` read-only ``[max_turn_rate]``.
        state_names: ``("x", "y", "heading")``.
        max_speed: ``speed`` (the airplane always flies at it).
        initial_heading: Heading of every airplane from :meth:`initial_states` (``pi / 4``).
    """

    name = "airplane"
    state_dim = 3
    control_dim = 1
    state_names: tuple[str, ...] = ("x", "y", "heading")
    control_names = ("turn_rate",)
    initial_heading = np.pi / 4

    def __init__(self, speed: float = 1.0, max_turn_rate: float = 0.5) -> None:
        self.speed = check_positive(speed, "speed")
        self.max_speed = self.speed
        self.max_turn_rate = check_positive(max_turn_rate, "max_turn_rate")
        self.control_low = _readonly(np.array([-self.max_turn_rate]))
        self.control_high = _readonly(np.array([self.max_turn_rate]))

    def step(self, states: FloatArray, controls: FloatArray, dt: float) -> FloatArray:
        """Fly every airplane along its arc for ``dt`` seconds.

        Args:
            states: ``(..., 3)`` states ``(x, y, heading)``.
            controls: ``(..., 1)`` turn rates; batch shapes broadcast (e.g. states ``(1, 3)``
                with ``(C, 1)`` candidate controls). Values outside the bounds are clipped.
            dt: Time step (> 0).

        Returns:
            ``(..., 3)`` next states, headings wrapped into ``[-pi, pi)``.

        Raises:
            ValueError: Wrong shapes, non-finite values or non-positive ``dt``.
        """
        s, c, dt_f = prepare_step_inputs(
            states, controls, dt, 3, 1, self.control_low, self.control_high
        )
        heading = s[..., 2]
        turn = c[..., 0] * dt_f
        mid_heading = heading + 0.5 * turn
        chord = self.speed * dt_f * np.sinc(turn / (2.0 * np.pi))  # np.sinc(a) = sin(pi a)/(pi a)
        out = np.empty(s.shape, dtype=np.float64)
        out[..., 0] = s[..., 0] + chord * np.cos(mid_heading)
        out[..., 1] = s[..., 1] + chord * np.sin(mid_heading)
        out[..., 2] = wrap_angle(heading + turn)
        return out

    def position(self, states: FloatArray) -> FloatArray:
        """``(..., 2)`` planar positions of ``(..., 3)`` states."""
        s = np.asarray(states, dtype=np.float64)
        if s.ndim < 1 or s.shape[-1] != 3:
            raise ValueError(f"states must have shape (..., 3), got {s.shape}")
        return s[..., :2]

    def initial_states(self, positions: FloatArray, rng: np.random.Generator) -> FloatArray:
        """Cruise states at ``(A, 2)`` positions, every heading ``initial_heading`` (pi/4).

        The fixed heading points from the usual start corner (the origin of the search
        domain) into the domain; ``rng`` is accepted for the protocol and not used.

        Returns:
            ``(A, 3)`` states.
        """
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        p = np.asarray(positions, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"positions must have shape (A, 2), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError("positions must be finite")
        heading = np.full((p.shape[0], 1), self.initial_heading)
        return np.concatenate([p, heading], axis=1)

    def __repr__(self) -> str:
        return f"Airplane(speed={self.speed}, max_turn_rate={self.max_turn_rate})"


def wrap_angle(angles: FloatArray) -> FloatArray:
    """Wrap angles into ``[-pi, pi)``."""
    wrapped = np.mod(np.asarray(angles, dtype=np.float64) + np.pi, 2.0 * np.pi)
    wrapped = np.where(wrapped >= 2.0 * np.pi, 0.0, wrapped)
    return wrapped - np.pi
