"""What a planner may know about an environment: the a-priori models, never the truth.

``Planner.from_env`` copies the sensor model the beliefs apply (``filter_sensor``), the vehicle
model, target space, time step, separation, action type and discrete control table from
``env.unwrapped`` into an :class:`EnvModel`; the planner never keeps the environment and never
reads the true target. :class:`Policy` is the protocol every policy satisfies.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.envs.targets import TargetSpace
from infoseek.envs.vehicles.base import Vehicle

FloatArray = NDArray[np.float64]

__all__ = ["EnvModel", "FloatArray", "Policy"]


@runtime_checkable
class Policy(Protocol):
    """Anything that maps a parallel-env step's observations and infos to actions."""

    def act(self, observations: Mapping[str, Any], infos: Mapping[str, Any]) -> dict[str, Any]:
        """Return ``{agent: action}`` for every agent in ``observations``."""
        ...


@dataclass(frozen=True)
class EnvModel:
    """The a-priori models a planner may know about an environment (no truth).

    Attributes:
        sensor: The measurement model the vehicles' beliefs apply (the environment's
            ``filter_sensor``: for ``beacon_v0`` the receiver with its noise floor), so the
            planners score candidates with exactly the likelihood the filters use.
        vehicle: The vehicle model shared by all vehicles.
        space: The target state space (search domain).
        dt: Time step.
        min_separation: The separation of eq. 2.
        action_type: ``"continuous"`` or ``"discrete"``.
        discrete_controls: ``(K, control_dim)`` control of each discrete action (None if
            continuous).
        possible_agents: Agent names; row ``i`` of ``vehicle_states`` belongs to agent ``i``.
        action_spaces: Agent name -> its gymnasium action space.
    """

    sensor: Sensor
    vehicle: Vehicle
    space: TargetSpace
    dt: float
    min_separation: float
    action_type: str
    discrete_controls: FloatArray | None
    possible_agents: tuple[str, ...]
    action_spaces: Mapping[str, Any]

    @classmethod
    def from_env(cls, env: Any) -> EnvModel:
        """Copy the a-priori models from ``env.unwrapped`` (never touches the truth)."""
        base = getattr(env, "unwrapped", env)
        config: Any = getattr(base, "config", None)
        missing = [
            name
            for name in (
                "filter_sensor",
                "vehicle",
                "space",
                "dt",
                "min_separation",
                "action_type",
                "discrete_controls",
            )
            if not hasattr(config, name)
        ]
        if missing or not hasattr(base, "possible_agents"):
            raise TypeError(
                "env: expected an infoseek InformationSeekingEnv (its settings in "
                f"env.unwrapped.config), missing {missing or ['possible_agents']}"
            )
        agents = tuple(base.possible_agents)
        discrete = config.discrete_controls
        if config.action_type not in ("continuous", "discrete"):
            raise ValueError(
                f"env.config.action_type must be continuous|discrete, got {config.action_type}"
            )
        if config.action_type == "discrete" and discrete is None:
            raise ValueError("env: discrete action type without discrete_controls")
        return cls(
            sensor=config.filter_sensor,
            vehicle=config.vehicle,
            space=config.space,
            dt=float(config.dt),
            min_separation=float(config.min_separation),
            action_type=str(config.action_type),
            discrete_controls=None
            if discrete is None
            else np.array(discrete, dtype=np.float64, copy=True),
            possible_agents=agents,
            action_spaces={agent: base.action_space(agent) for agent in agents},
        )

    @property
    def n_agents(self) -> int:
        """Number of possible agents."""
        return len(self.possible_agents)

    @property
    def control_low(self) -> FloatArray:
        """``(control_dim,)`` lower control bounds."""
        return np.asarray(self.vehicle.control_low, dtype=np.float64)

    @property
    def control_high(self) -> FloatArray:
        """``(control_dim,)`` upper control bounds."""
        return np.asarray(self.vehicle.control_high, dtype=np.float64)

    def agent_index(self, agent: str) -> int:
        """Row of ``agent`` in ``vehicle_states``; ValueError for an unknown name."""
        try:
            return self.possible_agents.index(agent)
        except ValueError:
            raise ValueError(
                f"unknown agent {agent!r}; possible agents are {list(self.possible_agents)}"
            ) from None
