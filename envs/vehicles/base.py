"""The vehicle model interface (eq. 1 of Hoffmann, Waslander & Tomlin 2006).

``x_{t+1} = f(x_t, u_t)``: a vehicle model advances a batch of vehicle states under a batch of
controls. States are ``(A, state_dim)``, controls ``(A, control_dim)``; the leading dimension
may be any batch (agents, or candidate controls of one agent). The position part of the state
(used by sensors and by the separation constraint of eq. 2) is ``states[..., :2]``.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@runtime_checkable
class Vehicle(Protocol):
    """A discrete-time vehicle model (eq. 1).

    Attributes:
        name: Short registry name (``"airplane"``, ``"quadrotor"``).
        state_dim: Length of a vehicle state.
        control_dim: Length of a control input.
        control_low: ``(control_dim,)`` lower control bounds.
        control_high: ``(control_dim,)`` upper control bounds.
        state_names: Name of each state coordinate (for observation manuals).
        max_speed: Upper bound on the vehicle's speed (distance units per second); bounds the
            positions an episode can reach (finite observation bounds).
    """

    name: str
    state_dim: int
    control_dim: int
    control_low: NDArray[np.float64]
    control_high: NDArray[np.float64]
    state_names: tuple[str, ...]
    max_speed: float

    def step(self, states: FloatArray, controls: FloatArray, dt: float) -> FloatArray:
        """Advance states by one time step.

        Args:
            states: ``(..., state_dim)`` current states.
            controls: ``(..., control_dim)`` controls, already inside the bounds (the caller
                clips); batch shapes broadcast.
            dt: Time step in seconds.

        Returns:
            ``(..., state_dim)`` next states.
        """
        ...

    def position(self, states: FloatArray) -> FloatArray:
        """``(..., 2)`` planar positions of ``(..., state_dim)`` states."""
        ...

    def initial_states(self, positions: FloatArray, rng: np.random.Generator) -> FloatArray:
        """States at rest/cruise for vehicles starting at ``(A, 2)`` positions."""
        ...
