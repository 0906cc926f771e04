"""Controls and actions: candidate grids, the control-to-action map and vehicle states.

Candidate controls are a tensor grid over the control bounds (continuous actions) or the
environment's discrete control table. Controls become actions as follows: continuous, the
control itself as ``float32`` clipped into the Box; discrete, the index of the nearest row of
``discrete_controls`` in control units scaled by the control range.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.model import EnvModel, FloatArray

__all__ = ["candidate_grid", "controls_to_actions", "nearest_discrete_action", "read_states"]


def candidate_grid(model: EnvModel, grid_size: int | None = None) -> FloatArray:
    """Candidate controls searched by the local programs.

    Args:
        model: The environment model.
        grid_size: Evenly spaced values per control axis (continuous actions only). ``None``:
            9 for a one-dimensional control (airplane turn rate), 5 per axis otherwise (5 x 5
            quadrotor accelerations). Both bounds are always included.

    Returns:
        ``(C, control_dim)`` candidates; exactly ``discrete_controls`` for discrete actions.
    """
    if model.action_type == "discrete":
        assert model.discrete_controls is not None
        return model.discrete_controls.copy()
    low, high = model.control_low, model.control_high
    dim = low.shape[0]
    k = (9 if dim == 1 else 5) if grid_size is None else int(grid_size)
    if k < 2:
        raise ValueError(f"grid_size must be >= 2, got {grid_size}")
    axes = [np.linspace(lo, hi, k) for lo, hi in zip(low, high, strict=True)]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=-1)


def nearest_discrete_action(model: EnvModel, controls: FloatArray) -> NDArray[np.int64]:
    """Index of the discrete control nearest to each ``(..., control_dim)`` control.

    Distances are measured in control units divided by the control range of each axis.
    """
    if model.discrete_controls is None:
        raise ValueError("nearest_discrete_action needs a discrete-action environment")
    scale = np.where(
        model.control_high > model.control_low, model.control_high - model.control_low, 1.0
    )
    controls = np.asarray(controls, dtype=np.float64)
    d = np.linalg.norm(
        (controls[..., None, :] - model.discrete_controls) / scale, axis=-1
    )  # (..., K)
    return np.argmin(d, axis=-1).astype(np.int64)


def controls_to_actions(
    model: EnvModel, agents: Sequence[str], controls: FloatArray
) -> dict[str, Any]:
    """Turn ``(len(agents), control_dim)`` controls into actions of each agent's action space.

    Continuous: the control as a ``float32`` array clipped into the Box. Discrete: the index of
    the nearest discrete control (an ``int``).
    """
    controls = np.asarray(controls, dtype=np.float64).reshape(len(agents), -1)
    if not np.isfinite(controls).all():
        raise ValueError(f"controls must be finite, got {controls}")
    actions: dict[str, Any] = {}
    if model.action_type == "discrete":
        indices = nearest_discrete_action(model, controls)
        for agent, k in zip(agents, indices, strict=True):
            actions[agent] = int(k)
        return actions
    for agent, u in zip(agents, controls, strict=True):
        space = model.action_spaces[agent]
        actions[agent] = np.clip(u.astype(np.float32), space.low, space.high).astype(np.float32)
    return actions


def read_states(model: EnvModel, infos: Mapping[str, Any], agents: Sequence[str]) -> FloatArray:
    """``(n_possible_agents, state_dim)`` vehicle states from ``infos[agent]["vehicle_states"]``.

    Raises:
        ValueError: No agents, an agent without ``infos`` / ``"vehicle_states"``, a wrong shape,
            or non-finite states.
    """
    if not agents:
        raise ValueError("observations: no agents to act for")
    agent = agents[0]
    if agent not in infos or "vehicle_states" not in infos[agent]:
        raise ValueError(f"infos[{agent!r}] must contain 'vehicle_states'")
    states = np.asarray(infos[agent]["vehicle_states"], dtype=np.float64)
    expected = (model.n_agents, model.vehicle.state_dim)
    if states.shape != expected:
        raise ValueError(
            f"infos[{agent!r}]['vehicle_states'] must have shape {expected}, got {states.shape}"
        )
    if not np.isfinite(states).all():
        raise ValueError(f"infos[{agent!r}]['vehicle_states'] contains non-finite values")
    return states
