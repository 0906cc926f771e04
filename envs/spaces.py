"""Observation and centralised-state layouts of the information-seeking environments.

Both are flat float32 vectors made of named blocks; every bound is finite.

**Reach.** A vehicle starts inside the box spanned by the domain and the start positions and
moves at most ``max_speed * dt`` per step, so within ``max_cycles`` steps its position stays in
that box grown by ``reach = max_speed * dt * max_cycles`` on every side. Positions are bounded by
this box and relative positions by its size; vehicle velocities by ``+-max_speed``, angles by
``[-pi, pi]``, belief-grid masses by ``[0, 1]`` and MMSE estimates by the domain.

**Observation of agent i** (the blocks ``observation_layout`` names, in order): ``own_state``
(its vehicle state), ``others_relative_positions`` (``x_j - x_i`` for ``j != i`` by index),
``belief_grid`` (its belief's mass on the coarse grid, x index slowest), ``mmse_estimate``
(its belief's MMSE estimate, eq. 12, every target coordinate) and, with
``belief_moments=True``, ``belief_moments``: the own belief's planar position spread
``(s_x, s_y, rho, m)`` -- the weighted standard deviations
``s_x = sqrt(sum_n w_n (x_n - xbar)^2)`` and ``s_y`` (bounded by the domain's width and
height), the correlation ``rho = c_xy / (s_x s_y)`` in ``[-1, 1]`` (0 when a deviation is 0)
and the posterior mass within the localisation radius of the MMSE estimate, in ``[0, 1]``.
The 8 x 8 grid cannot show the shape of a belief smaller than a cell; these four numbers can.

**Centralised state** (``state_layout``; what a centralised critic should see, never the true
target): ``vehicle_states`` (every vehicle's state, agent 0 first), ``belief_grids`` (every
agent's belief grid), ``mmse_estimates`` (every agent's MMSE estimate), ``posterior_masses``
(every agent's posterior mass within the localisation radius of its estimate, in ``[0, 1]``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.targets import TargetSpace

FloatArray = NDArray[np.float64]

__all__ = ["ANGLE_STATE_NAMES", "Layout", "observation_layout", "position_box", "state_layout"]

#: Vehicle state names that are angles in ``[-pi, pi]``.
ANGLE_STATE_NAMES = ("heading", "psi", "yaw")

#: Block name -> slice of the flat vector, and the ``(low, high)`` bounds of the whole vector.
Layout = tuple[dict[str, slice], FloatArray, FloatArray]


def position_box(
    space: TargetSpace, start_positions: FloatArray, max_speed: float, dt: float, max_cycles: int
) -> tuple[FloatArray, FloatArray]:
    """``(2,)`` low and high corners of the box every vehicle position stays in (the reach)."""
    reach = float(max_speed) * float(dt) * int(max_cycles)
    low = np.minimum(space.low_array[:2], start_positions.min(axis=0)) - reach
    high = np.maximum(space.high_array[:2], start_positions.max(axis=0)) + reach
    return low, high


def _state_bounds(
    state_names: Sequence[str], max_speed: float, box: tuple[FloatArray, FloatArray]
) -> tuple[FloatArray, FloatArray]:
    low = np.empty(len(state_names))
    high = np.empty(len(state_names))
    for k, name in enumerate(state_names):
        if name in ANGLE_STATE_NAMES:
            low[k], high[k] = -np.pi, np.pi
        elif name in ("x", "y"):
            axis = 0 if name == "x" else 1
            low[k], high[k] = box[0][axis], box[1][axis]
        elif name in ("vx", "vy"):
            low[k], high[k] = -max_speed, max_speed
        else:
            raise ValueError(
                f"no bound known for vehicle state {name!r}; known: x, y, vx, vy, "
                f"{', '.join(ANGLE_STATE_NAMES)}"
            )
    return low, high


def _assemble(blocks: list[tuple[str, FloatArray, FloatArray]]) -> Layout:
    layout: dict[str, slice] = {}
    start = 0
    for name, low, _ in blocks:
        layout[name] = slice(start, start + low.size)
        start += low.size
    return (
        layout,
        np.concatenate([b[1] for b in blocks]),
        np.concatenate([b[2] for b in blocks]),
    )


def observation_layout(
    state_names: Sequence[str],
    max_speed: float,
    box: tuple[FloatArray, FloatArray],
    space: TargetSpace,
    n_agents: int,
    belief_grid: tuple[int, int],
    *,
    belief_moments: bool = False,
) -> Layout:
    """Layout and bounds of one agent's observation (module docstring).

    Args:
        state_names: The vehicle's state names.
        max_speed: The vehicle's speed bound.
        box: :func:`position_box`.
        space: The target space (its position box bounds the MMSE estimate).
        n_agents: Vehicles in the team.
        belief_grid: ``(gx, gy)`` cells of the coarse belief grid.
        belief_moments: Append the ``belief_moments`` block.
    """
    state_low, state_high = _state_bounds(state_names, max_speed, box)
    span = np.tile(box[1] - box[0], n_agents - 1)
    n_grid = belief_grid[0] * belief_grid[1]
    blocks = [
        ("own_state", state_low, state_high),
        ("others_relative_positions", -span, span),
        ("belief_grid", np.zeros(n_grid), np.ones(n_grid)),
        ("mmse_estimate", space.low_array.copy(), space.high_array.copy()),
    ]
    if belief_moments:
        size = space.high_array[:2] - space.low_array[:2]
        blocks.append(
            ("belief_moments", np.array([0.0, 0.0, -1.0, 0.0]), np.array([*size, 1.0, 1.0]))
        )
    return _assemble(blocks)


def state_layout(
    state_names: Sequence[str],
    max_speed: float,
    box: tuple[FloatArray, FloatArray],
    space: TargetSpace,
    n_agents: int,
    belief_grid: tuple[int, int],
) -> Layout:
    """Layout and bounds of the centralised state (module docstring); arguments as
    :func:`observation_layout`."""
    state_low, state_high = _state_bounds(state_names, max_speed, box)
    n_grid = belief_grid[0] * belief_grid[1] * n_agents
    return _assemble(
        [
            ("vehicle_states", np.tile(state_low, n_agents), np.tile(state_high, n_agents)),
            ("belief_grids", np.zeros(n_grid), np.ones(n_grid)),
            (
                "mmse_estimates",
                np.tile(space.low_array, n_agents),
                np.tile(space.high_array, n_agents),
            ),
            ("posterior_masses", np.zeros(n_agents), np.ones(n_agents)),
        ]
    )
