"""Planar quadrotor model for the rescue-beacon search of section IV.B.

"They accelerate laterally proportional to their tilt, with constraints on speed,
acceleration, and proximity." The horizontal dynamics are a double integrator whose control is
the commanded horizontal acceleration (proportional to the tilt angle for small tilts).

State ``x = (x, y, vx, vy)``, control ``u = (ax, ay)`` with ``|ax|, |ay| <= max_accel``:

    v~ = v + u dt
    v' = v~ * min(1, max_speed / ||v~||)          (speed limit, norm clipping)
    p' = p + (v + v') dt / 2                      (trapezoidal position update)

Without the speed limit this is the exact integral of constant acceleration.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.vehicles.airplane import check_positive, prepare_step_inputs

FloatArray = NDArray[np.float64]

__all__ = ["Quadrotor"]


class Quadrotor:
    """Planar double integrator with per-axis acceleration limits and a speed limit.

    Args:
        max_accel: Per-axis acceleration limit (> 0); control bounds ``+-max_accel``.
        max_speed: Speed limit (> 0) on the norm of the velocity.

    Attributes:
        name: ``"quadrotor"``.
        state_dim: 4, ``(x, y, vx, vy)``.
        control_dim: 2, ``(ax, ay)``.
        control_low: ``(2,)`` read-only ``[-max_accel, -max_accel]``.
        control_high: ``(2,)`` read-only ``[max_accel, max_accel]``.
        state_names: ``("x", "y", "vx", "vy")``.
        max_speed: The speed limit.
    """

    name = "quadrotor"
    state_dim = 4
    control_dim = 2
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy")
    control_names = ("ax", "ay")

    def __init__(self, max_accel: float = 1.0, max_speed: float = 2.0) -> None:
        self.max_accel = check_positive(max_accel, "max_accel")
        self.max_speed = check_positive(max_speed, "max_speed")
        low = np.full(2, -self.max_accel)
        high = np.full(2, self.max_accel)
        low.flags.writeable = False
        high.flags.writeable = False
        self.control_low = low
        self.control_high = high

    def step(self, states: FloatArray, controls: FloatArray, dt: float) -> FloatArray:
        """Advance every quadrotor by ``dt`` (see the module docstring).

        Args:
            states: ``(..., 4)`` states ``(x, y, vx, vy)``.
            controls: ``(..., 2)`` commanded accelerations; batch shapes broadcast (e.g.
                states ``(1, 4)`` with ``(C, 2)`` candidates). Out-of-bound values are clipped.
            dt: Time step (> 0).

        Returns:
            ``(..., 4)`` next states; ``||v'|| <= max_speed``.

        Raises:
            ValueError: Wrong shapes, non-finite values or non-positive ``dt``.
        """
        s, c, dt_f = prepare_step_inputs(
            states, controls, dt, 4, 2, self.control_low, self.control_high
        )
        velocity = s[..., 2:]
        new_velocity = velocity + c * dt_f
        speed = np.linalg.norm(new_velocity, axis=-1, keepdims=True)
        scale = np.minimum(1.0, self.max_speed / np.maximum(speed, 1e-300))
        new_velocity = new_velocity * scale
        out = np.empty(s.shape, dtype=np.float64)
        out[..., :2] = s[..., :2] + 0.5 * (velocity + new_velocity) * dt_f
        out[..., 2:] = new_velocity
        return out

    def position(self, states: FloatArray) -> FloatArray:
        """``(..., 2)`` planar positions of ``(..., 4)`` states."""
        s = np.asarray(states, dtype=np.float64)
        if s.ndim < 1 or s.shape[-1] != 4:
            raise ValueError(f"states must have shape (..., 4), got {s.shape}")
        return s[..., :2]

    def initial_states(self, positions: FloatArray, rng: np.random.Generator) -> FloatArray:
        """Hovering states (zero velocity) at ``(A, 2)`` positions; ``rng`` is unused.

        Returns:
            ``(A, 4)`` states.
        """
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        p = np.asarray(positions, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"positions must have shape (A, 2), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError("positions must be finite")
        return np.concatenate([p, np.zeros_like(p)], axis=1)

    def __repr__(self) -> str:
        return f"Quadrotor(max_accel={self.max_accel}, max_speed={self.max_speed})"
