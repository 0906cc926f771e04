r"""Receding-horizon information planner: each vehicle plans ``H`` steps ahead.

The paper's planners are one-step greedy: vehicle :math:`i` maximises the information of its
*next* observation (with the pairwise terms of its partners' next observations, eq. 22). This
planner keeps their decentralised coordination but scores whole control *sequences*:

* **Candidates.** A sequence is a first control ``u_1`` from the control grid (as the greedy
  planners') followed by a second control ``u_2`` from a coarser grid held for steps
  ``2..H``; ``u_1`` is executed and the plan is recomputed at the next step (receding
  horizon). With the defaults (9 x 5 controls, ``H = 5``) an airplane weighs 45 sequences,
  among them every full turn and every "turn now, then hold" manoeuvre.
* **Utility.** The information that *all* the team's planned observations over the horizon,
  :math:`Z = \{z^{(j)}_{t+1..t+H}\}_j`, carry about the target on vehicle :math:`i`'s own
  belief, with the other vehicles' latest plans held fixed (exact copies, as the greedy
  planners' eq. 30 realisation). Up to ``n_v H`` observations enter jointly, so the
  redundancy between a vehicle's own successive bearings and between vehicles is counted
  (a sum of per-step terms would count it many times). The information is the Bhattacharyya
  pairwise-distance lower bound :math:`\hat I_B \le I(Z; \theta)` of
  :mod:`~infoseek.planners.horizon_information` on ``n_planning`` planning particles (default
  128, a subsample of the belief by the planner's generator), computed with the same sensor
  model the beliefs use. The bound is exact when the hypotheses' predicted observation
  sequences coincide or are far apart; between those limits it is a smooth lower bound, not
  the exact MI (the approximation of this planner, besides the open-loop horizon: future
  observations do not change future plans).
* **Coordination.** :func:`~infoseek.planners.coordination.coordinate` with the sequences'
  tracks over the whole horizon as the positions, so the separation penalty (eq. 27-28)
  holds over ``H`` steps; the initial exchange is every vehicle's best sequence on its own
  observations alone. With identical beliefs the utilities are one team function
  (the bound of the team's observations), so the Gauss-Seidel sweeps are coordinate ascent on
  it, as for the pairwise-node planner.

Cost per step and vehicle: the pair terms ``log rho`` at the own poses (``C H N^2`` table
lookups once per step, fewer by the first poses that sequences with the same first control
share) and at each partner plan's ``H`` poses (cached per plan), then per local solve
``C N^2`` sums and exponentials (cached per set of partner plans: later sweeps repeat some);
with the defaults (``C = 45``, ``H = 5``, ``N = 128``) about 3.1 M lookups per vehicle and
step. The lookups and the sums run as compiled kernels
(:mod:`~infoseek.planners.horizon_affinity`, :mod:`~infoseek.planners.horizon_bound`) with
the numbers of the NumPy expressions they replaced. Needs an additive-noise sensor with one
observation coordinate (bearing, range), not the beacon.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.base import PlanDiagnostics, Planner, planning_beliefs
from infoseek.planners.config import PlannerConfig, check_positive_integers
from infoseek.planners.controls import candidate_grid, controls_to_actions
from infoseek.planners.coordination import coordinate
from infoseek.planners.horizon_information import HorizonInformation
from infoseek.planners.model import EnvModel, FloatArray
from infoseek.planners.utilities import PlanningBelief

__all__ = ["RecedingHorizonConfig", "RecedingHorizonPlanner"]


@dataclass(frozen=True)
class RecedingHorizonConfig(PlannerConfig):
    """Options of :class:`RecedingHorizonPlanner`: those of
    :class:`~infoseek.planners.config.PlannerConfig` (``mi_method``, ``quadrature_points``,
    ``refine`` and ``safety_horizon`` are not used) plus:

    Attributes:
        n_planning: Planning particles per vehicle (128; the cost is quadratic in it).
        horizon: Steps planned ahead ``H`` (5, >= 1; 1 is a greedy planner on the bound).
        hold_grid_size: Controls per axis of the held second segment (5; discrete actions use
            the environment's table for both segments).
    """

    n_planning: int = 128
    horizon: int = 5
    hold_grid_size: int = 5

    def __post_init__(self) -> None:
        super().__post_init__()
        check_positive_integers(self, ("horizon", "hold_grid_size"))
        if self.hold_grid_size < 2:
            raise ValueError(f"hold_grid_size must be >= 2, got {self.hold_grid_size}")


class RecedingHorizonPlanner(Planner):
    """Decentralised receding-horizon planner on the team's horizon information (module
    docstring). Build with ``RecedingHorizonPlanner.from_env(env, **options)``; options are the
    fields of :class:`RecedingHorizonConfig`."""

    config_class = RecedingHorizonConfig

    def __init__(self, model: EnvModel, config: RecedingHorizonConfig) -> None:
        super().__init__(model, config)
        self.rng = np.random.default_rng(config.seed)
        self.settings = config.penalty_settings(model.min_separation)
        self.information = HorizonInformation(model.sensor)
        first = candidate_grid(model, config.grid_size)
        hold = candidate_grid(model, config.hold_grid_size)
        h = config.horizon
        pairs = [
            (a, b) for a in range(first.shape[0]) for b in range(hold.shape[0] if h > 1 else 1)
        ]
        #: ``(C, H, control_dim)`` candidate control sequences.
        self.sequences = np.stack(
            [
                np.concatenate([first[a][None], np.repeat(hold[b][None], h - 1, axis=0)])
                for a, b in pairs
            ]
        )

    def _tracks(self, states: FloatArray) -> FloatArray:
        """``(A, C, H, 2)`` positions of every vehicle flying every sequence."""
        vehicle = self.model.vehicle
        n_vehicles, (n_seq, horizon, dim) = states.shape[0], self.sequences.shape
        current = np.repeat(states, n_seq, axis=0)
        steps = []
        for t in range(horizon):
            controls = np.tile(self.sequences[:, t, :], (n_vehicles, 1)).reshape(-1, dim)
            current = vehicle.step(current, controls, self.model.dt)
            steps.append(np.asarray(vehicle.position(current), dtype=np.float64))
        return np.stack(steps, axis=1).reshape(n_vehicles, n_seq, horizon, 2)

    def _plan(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        start = time.perf_counter()
        rows = [self.model.agent_index(agent) for agent in agents]
        tracks = self._tracks(states[rows])
        n_vehicles, n_seq = tracks.shape[:2]
        beliefs = planning_beliefs(agents, infos, self.config.n_planning, self.rng)
        tic = time.perf_counter()
        utility = _SequenceUtilities(self.information, beliefs, tracks)
        alone = [utility.alone(i) for i in range(n_vehicles)]
        utility.seconds = time.perf_counter() - tic  # the information work; each call adds
        flat = self.sequences.reshape(n_seq, -1)
        result = coordinate(
            [flat] * n_vehicles,
            list(tracks),
            utility,
            self.settings,
            initial_indices=np.array([int(np.argmax(v)) for v in alone], dtype=np.int64),
        )
        controls = self.sequences[result.indices, 0, :]
        actions = controls_to_actions(self.model, agents, controls)
        self.last_plan = PlanDiagnostics.from_coordination(
            agents,
            controls,
            result,
            grid_controls=controls,
            refined=False,
            planning_time=time.perf_counter() - start,
            utility_time=utility.seconds,
        )
        return actions


class _SequenceUtilities:
    """Each vehicle's horizon bound of its sequences given its partners' plans, the pair sums
    and the values cached for one decision.

    ``own[i]`` holds the ``(C, N, N)`` pair sums of vehicle ``i``'s sequences on its planning
    particles; a partner plan's ``(N, N)`` sums on ``i``'s particles are computed at its first
    use; a utility asked again with the same partner plans (the coordination's later sweeps
    often do) is returned from the cache: the same arrays give the same bits.

    Args:
        information: The bound.
        beliefs: Each vehicle's planning particles.
        tracks: ``(A, C, H, 2)`` positions of every vehicle flying every sequence.
    """

    def __init__(
        self, information: HorizonInformation, beliefs: list[PlanningBelief], tracks: FloatArray
    ) -> None:
        self.information = information
        self.beliefs = beliefs
        self.tracks = tracks
        self.own = [
            information.pose_term_sums(b.particles, tracks[i]) for i, b in enumerate(beliefs)
        ]
        self._partner_terms: list[dict[tuple[int, int], FloatArray]] = [{} for _ in beliefs]
        self._values: list[dict[tuple[tuple[int, int], ...], FloatArray]] = [{} for _ in beliefs]
        #: Seconds spent in utility evaluations.
        self.seconds = 0.0

    def alone(self, i: int) -> FloatArray:
        """``(C,)`` vehicle ``i``'s bound of its own observations only."""
        return self._value(i, ())

    def __call__(self, i: int, plans: NDArray[np.int64]) -> FloatArray:
        """``(C,)`` vehicle ``i``'s bound with every other vehicle ``j`` flying ``plans[j]``."""
        tic = time.perf_counter()
        keys = tuple((j, int(plans[j])) for j in range(len(self.beliefs)) if j != i)
        value = self._value(i, keys)
        self.seconds += time.perf_counter() - tic
        return value

    def _value(self, i: int, keys: tuple[tuple[int, int], ...]) -> FloatArray:
        """The bound of vehicle ``i`` with the partner plans ``keys`` (``(j, sequence)``), the
        partners' pair sums added in the order of ``keys``."""
        if keys not in self._values[i]:
            cache, particles = self._partner_terms[i], self.beliefs[i].particles
            for key in keys:
                if key not in cache:
                    poses = self.tracks[key[0], key[1]][None]
                    cache[key] = self.information.pose_term_sums(particles, poses)[0]
            own = self.own[i]
            partners = np.stack([cache[key] for key in keys]) if keys else own[:0]
            value = self.information.bound(own, partners, self.beliefs[i].weights)
            self._values[i][keys] = value
        return self._values[i][keys].copy()
