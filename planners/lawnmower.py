"""Boustrophedon ("lawnmower") coverage baseline.

The domain's position box ``[low_x, high_x] x [low_y, high_y]`` (from the target space) is cut
into ``A`` vertical strips of equal width, one per possible agent (agent ``i`` gets strip
``i`` from the left). Inside its strip a vehicle flies lanes parallel to the ``y`` axis:
``n_lanes = ceil(strip_width / sweep_width)`` lanes at the centres of equal sub-strips, so
adjacent lanes are at most ``sweep_width`` apart (the documented sweep width: the band one
pass is meant to cover; default 4 units, i.e. 10 lanes across the paper's 40-unit domain).
Lanes run from ``low_y + margin`` to ``high_y - margin``, alternating direction; the waypoint
list is ``(x_0, y_lo), (x_0, y_hi), (x_1, y_hi), (x_1, y_lo), ...``. When the last waypoint is
reached the list is flown backwards, and so on.

A waypoint counts as reached within ``capture_radius``. Steering uses the vehicle's own
controls:

* airplane (turn-rate control): pure pursuit, ``u = clip(k_heading * wrap(bearing - heading),
  -max_turn_rate, max_turn_rate)`` with ``k_heading = 1 / dt`` by default (the turn rate that
  would null the heading error in one step, saturated);
* quadrotor (acceleration control): PD on position, ``a = kp (w - p) - kd v``, clipped per axis
  to the acceleration bounds;
* any other vehicle: the grid control whose predicted next position is closest to the waypoint.

Discrete-action environments receive the nearest discrete control. The policy never reads the
belief or the truth.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from infoseek.planners.base import Planner
from infoseek.planners.controls import candidate_grid, controls_to_actions
from infoseek.planners.model import EnvModel, FloatArray

__all__ = ["LawnmowerConfig", "LawnmowerPolicy", "lawnmower_waypoints"]


@dataclass(frozen=True)
class LawnmowerConfig:
    """Options of :class:`LawnmowerPolicy`.

    Attributes:
        sweep_width: Largest spacing between adjacent lanes, in distance units (> 0).
        margin: Inset of the lane ends and strip edges from the domain boundary (>= 0).
        capture_radius: Distance at which a waypoint counts as reached (> 0); default 2.5
            (larger than an airplane's default turn radius of 2 so it cannot orbit a waypoint).
        heading_gain: Airplane pursuit gain ``k_heading`` (1/s); ``None`` means ``1 / dt``.
        kp: Quadrotor position gain (1/s^2, > 0).
        kd: Quadrotor velocity damping gain (1/s, >= 0).
        seed: Accepted so that every policy is built the same way (``from_env(env,
            seed=...)``); unused, the pattern is deterministic.
    """

    sweep_width: float = 4.0
    margin: float = 2.0
    capture_radius: float = 2.5
    heading_gain: float | None = None
    kp: float = 0.3
    kd: float = 1.0
    seed: int | None = None

    def __post_init__(self) -> None:
        for name in ("sweep_width", "capture_radius", "kp"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        for name in ("margin", "kd"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if self.heading_gain is not None and not (
            np.isfinite(self.heading_gain) and self.heading_gain > 0
        ):
            raise ValueError(f"heading_gain must be None or > 0, got {self.heading_gain}")


@dataclass(frozen=True)
class LawnmowerPlan:
    """Diagnostics of one :meth:`LawnmowerPolicy.act` call.

    Attributes:
        waypoints: Agent -> ``(2,)`` waypoint steered to.
        controls: Agent -> ``(control_dim,)`` control before mapping to an action.
    """

    waypoints: Mapping[str, FloatArray]
    controls: Mapping[str, FloatArray]


def lawnmower_waypoints(
    low: FloatArray, high: FloatArray, n_strips: int, strip: int, sweep_width: float, margin: float
) -> FloatArray:
    """Boustrophedon waypoints of one strip.

    Args:
        low: ``(2,)`` lower corner of the domain.
        high: ``(2,)`` upper corner of the domain.
        n_strips: Number of vertical strips.
        strip: Index of the strip (0 = leftmost).
        sweep_width: Largest lane spacing.
        margin: Inset of lane ends from the boundary.

    Returns:
        ``(2 n_lanes, 2)`` waypoints.
    """
    low = np.asarray(low, dtype=np.float64)
    high = np.asarray(high, dtype=np.float64)
    width = (high[0] - low[0]) / n_strips
    x0 = low[0] + strip * width
    n_lanes = max(1, math.ceil(width / sweep_width - 1e-9))
    lanes = x0 + (np.arange(n_lanes) + 0.5) * width / n_lanes
    y_lo = low[1] + min(margin, 0.5 * (high[1] - low[1]))
    y_hi = high[1] - min(margin, 0.5 * (high[1] - low[1]))
    points = []
    for k, x in enumerate(lanes):
        ends = (y_lo, y_hi) if k % 2 == 0 else (y_hi, y_lo)
        points.extend([(x, ends[0]), (x, ends[1])])
    return np.asarray(points, dtype=np.float64)


class LawnmowerPolicy(Planner):
    """Boustrophedon coverage with one strip per vehicle (a baseline)."""

    config_class = LawnmowerConfig

    def __init__(self, model: EnvModel, config: LawnmowerConfig) -> None:
        super().__init__(model, config)
        low = np.asarray(model.space.low, dtype=np.float64)[:2]
        high = np.asarray(model.space.high, dtype=np.float64)[:2]
        self.waypoints = [
            lawnmower_waypoints(low, high, model.n_agents, i, config.sweep_width, config.margin)
            for i in range(model.n_agents)
        ]
        self._grid = candidate_grid(model)
        self.reset()

    def reset(self) -> None:
        """Restart every vehicle at the first waypoint of its strip."""
        super().reset()
        self._next = np.zeros(self.model.n_agents, dtype=np.int64)
        self._direction = np.ones(self.model.n_agents, dtype=np.int64)

    def _advance(self, i: int, position: FloatArray) -> FloatArray:
        route = self.waypoints[i]
        for _ in range(len(route) + 1):
            target = route[self._next[i]]
            if np.linalg.norm(target - position) > self.config.capture_radius:
                return target
            if len(route) == 1:
                return target
            nxt = self._next[i] + self._direction[i]
            if not 0 <= nxt < len(route):
                self._direction[i] = -self._direction[i]
                nxt = self._next[i] + self._direction[i]
            self._next[i] = nxt
        return route[self._next[i]]

    def _steer(self, state: FloatArray, waypoint: FloatArray) -> FloatArray:
        vehicle = self.model.vehicle
        low, high = self.model.control_low, self.model.control_high
        position = np.asarray(vehicle.position(state), dtype=np.float64)
        if vehicle.name == "airplane":
            gain = (
                1.0 / self.model.dt
                if self.config.heading_gain is None
                else self.config.heading_gain
            )
            bearing = math.atan2(waypoint[1] - position[1], waypoint[0] - position[0])
            error = (bearing - state[2] + math.pi) % (2 * math.pi) - math.pi
            return np.clip(np.array([gain * error]), low, high)
        if vehicle.name == "quadrotor":
            velocity = state[2:4]
            accel = self.config.kp * (waypoint - position) - self.config.kd * velocity
            return np.clip(accel, low, high)
        nxt = np.asarray(vehicle.step(state[None, :], self._grid, self.model.dt))
        distance = np.linalg.norm(vehicle.position(nxt) - waypoint, axis=-1)
        return self._grid[int(np.argmin(distance))]

    def _plan(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        controls = []
        waypoints: dict[str, FloatArray] = {}
        control_map: dict[str, FloatArray] = {}
        for agent in agents:
            i = self.model.agent_index(agent)
            position = np.asarray(self.model.vehicle.position(states[i]), dtype=np.float64)
            waypoint = self._advance(i, position)
            u = self._steer(states[i], waypoint)
            controls.append(u)
            waypoints[agent] = waypoint.copy()
            control_map[agent] = u.copy()
        self.last_plan = LawnmowerPlan(waypoints=waypoints, controls=control_map)
        return controls_to_actions(self.model, agents, np.asarray(controls))
