"""The planner interface and the shared machinery of the information planners.

Every policy in :mod:`infoseek.planners` is used the same way inside the ordinary PettingZoo
parallel loop::

    planner = PairwiseNodePlanner.from_env(env, seed=0)
    observations, infos = env.reset(seed=0)
    while env.agents:
        actions = planner.act(observations, infos)
        observations, rewards, terminations, truncations, infos = env.step(actions)

``from_env`` copies the a-priori models into an :class:`~infoseek.planners.model.EnvModel`
and parses the options (:mod:`infoseek.planners.config`). ``act`` reads, for every agent
present in ``observations``, its own belief ``infos[agent]["belief"]`` (build the environment
with ``belief_in_infos=True``: by default infos hold only numbers and arrays) and the vehicle
states ``infos[agent]["vehicle_states"]`` (rows in ``possible_agents`` order), and returns one
action per agent inside ``env.action_space(agent)`` (:mod:`infoseek.planners.controls`).
"""

from __future__ import annotations

import contextlib
import os
import time
from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Self

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.config import PlannerConfig, parse_options
from infoseek.planners.controls import candidate_grid, controls_to_actions, read_states
from infoseek.planners.coordination import CoordinationResult, UtilityFunction, coordinate
from infoseek.planners.information import BeliefMI
from infoseek.planners.information.base import single_many
from infoseek.planners.model import EnvModel, FloatArray
from infoseek.planners.refinement import GridRefiner
from infoseek.planners.utilities import PlanningBelief, subsample_particles

__all__ = ["FloatArray", "InformationPlanner", "PlanDiagnostics", "Planner", "planning_beliefs"]


def planning_beliefs(
    agents: list[str], infos: Mapping[str, Any], n_planning: int, rng: np.random.Generator
) -> list[PlanningBelief]:
    """Each agent's own belief ``infos[agent]["belief"]``, subsampled to ``n_planning``
    equally weighted planning particles with ``rng``.

    Raises:
        ValueError: An agent's infos hold no belief (the env was built without
            ``belief_in_infos=True``).
    """
    beliefs = []
    for agent in agents:
        info = infos[agent]
        if "belief" not in info:
            raise ValueError(
                f"infos[{agent!r}] has no 'belief': build the environment with "
                "belief_in_infos=True (the information planners read each agent's own "
                "belief from its infos)"
            )
        beliefs.append(subsample_particles(info["belief"], n_planning, rng))
    return beliefs


class Planner(ABC):
    """Base class of the scripted policies.

    Subclasses set :attr:`config_class` (a frozen dataclass listing every option) and implement
    :meth:`_plan`. ``planner.last_plan`` holds the diagnostics of the last :meth:`act` call.
    """

    config_class: ClassVar[type]

    def __init__(self, model: EnvModel, config: Any) -> None:
        self.model = model
        self.config = config
        self.last_plan: Any = None

    @classmethod
    def from_env(cls, env: Any, **options: Any) -> Self:
        """Build the planner for ``env`` with the given options.

        Raises:
            ValueError: Unknown option (the message lists the valid ones) or invalid value.
        """
        model = EnvModel.from_env(env)
        return cls(model, parse_options(cls.config_class, options))

    def act(self, observations: Mapping[str, Any], infos: Mapping[str, Any]) -> dict[str, Any]:
        """Actions ``{agent: action}`` for every agent in ``observations``.

        Args:
            observations: This step's observations (only the keys are used: they name the
                agents still active).
            infos: This step's infos; ``infos[agent]`` must hold ``"belief"`` (for the
                information planners; an env built with ``belief_in_infos=True``) and
                ``"vehicle_states"``.

        Returns:
            One action per active agent, inside ``action_space(agent)``.
        """
        agents = list(observations)
        for agent in agents:
            self.model.agent_index(agent)
            if agent not in infos:
                raise ValueError(f"infos has no entry for agent {agent!r}")
        if not agents:
            return {}
        states = read_states(self.model, infos, agents)
        return self._plan(agents, states, infos)

    @abstractmethod
    def _plan(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        """Compute the actions of ``agents`` from ``(n_possible_agents, state_dim)`` states."""

    def reset(self) -> None:
        """Forget per-episode state (the default planners keep none besides diagnostics)."""
        self.last_plan = None


@dataclass(frozen=True)
class PlanDiagnostics:
    """What one :meth:`InformationPlanner.act` call did.

    Attributes:
        agents: The agents planned for (active agents, in ``observations`` order).
        controls: ``(A, control_dim)`` controls sent (after refinement).
        grid_controls: ``(A, control_dim)`` controls chosen on the candidate grid.
        utilities: ``(A,)`` utility of each grid plan against the final partner plans.
        iterations: Coordination sweeps performed.
        converged: Whether the coordination stopping rule was met.
        max_violation: Largest planned shortfall below the planning separation (grid plans).
        agreement_residual: Largest disagreement between the slack copies and the final plans.
        beta: Penalty parameter of the last sweep.
        refined: Whether continuous refinement ran.
        planning_time: Wall-clock seconds of the whole ``act`` call.
        utility_time: Seconds spent in utility (MI) evaluations.
    """

    agents: tuple[str, ...]
    controls: FloatArray
    grid_controls: FloatArray
    utilities: FloatArray
    iterations: int
    converged: bool
    max_violation: float
    agreement_residual: float
    beta: float
    refined: bool
    planning_time: float
    utility_time: float

    @classmethod
    def from_coordination(
        cls,
        agents: list[str],
        controls: FloatArray,
        result: CoordinationResult,
        *,
        refined: bool,
        planning_time: float,
        utility_time: float,
        grid_controls: FloatArray | None = None,
    ) -> PlanDiagnostics:
        """The diagnostics of a decision whose coordination returned ``result`` and whose sent
        controls are ``controls`` (``grid_controls``: default ``result.controls``)."""
        return cls(
            agents=tuple(agents),
            controls=controls,
            grid_controls=result.controls if grid_controls is None else grid_controls,
            utilities=result.utilities,
            iterations=result.iterations,
            converged=result.converged,
            max_violation=result.max_violation,
            agreement_residual=result.agreement_residual,
            beta=result.beta,
            refined=refined,
            planning_time=planning_time,
            utility_time=utility_time,
        )


class BlasThreads:
    """The BLAS thread count a planner decides with: one, as every stored trial runs
    (:func:`infoseek.experiments.bench.run_trial`), unless ``INFOSEEK_THREADS`` says otherwise
    (a count, or ``0`` for the library's default).

    The utilities are many small float32 matrix products: a second OpenBLAS thread gains little
    on them and, on a machine whose other cores are busy, waits for a core (a four-airplane
    decision took ~40 ms instead of ~4 ms with two threads on a shared 2-core machine). OpenBLAS
    also sums some products in another order with another thread count, so one thread makes a
    planner called from Python decide as the stored trials did. The limit holds during
    :meth:`Planner.act` only (``threadpoolctl``; the controller is built on first use).
    """

    def __init__(self) -> None:
        self._controller: Any = None

    @staticmethod
    def count() -> int | None:
        """The thread count (``None``: leave the library's default).

        Raises:
            ValueError: ``INFOSEEK_THREADS`` is not a non-negative integer.
        """
        text = os.environ.get("INFOSEEK_THREADS", "1").strip()
        if not text.isdigit():
            raise ValueError(
                f"INFOSEEK_THREADS={text!r}: expected a number of threads (0: default)"
            )
        return int(text) or None

    @contextlib.contextmanager
    def limited(self) -> Iterator[None]:
        """Run the block with :meth:`count` BLAS threads."""
        count = self.count()
        if count is None:
            yield
            return
        if self._controller is None:
            from threadpoolctl import ThreadpoolController

            self._controller = ThreadpoolController()
        with self._controller.limit(limits=count, user_api="blas"):
            yield


class InformationPlanner(Planner):
    """Shared machinery of the mutual-information planners.

    One :meth:`act` call: (1) read the vehicle states and each active agent's own belief;
    (2) subsample each belief to ``n_planning`` planning particles with the planner's generator;
    (3) predict every candidate control's next position with the vehicle model; (4) compute the
    single-node utilities (eq. 20) of every agent's candidates in one batched call per agent;
    (5) run the penalty coordination (:func:`~infoseek.planners.coordination.coordinate`) with the
    subclass's utility; (6) for continuous actions, refine each vehicle's grid choice in
    Gauss-Seidel order against the others' latest plans with the last penalty weight; (7) map the
    controls to actions. Subclasses provide :meth:`_utility_function`.
    """

    config_class = PlannerConfig
    min_agents: ClassVar[int] = 1
    #: Joint observations of one utility term (1 single-node, 2 pairwise-node).
    observations_per_term: ClassVar[int] = 1

    def __init__(self, model: EnvModel, config: PlannerConfig) -> None:
        if model.n_agents < self.min_agents:
            raise ValueError(
                f"{type(self).__name__} needs at least {self.min_agents} agents, the environment "
                f"has n_agents={model.n_agents}"
            )
        super().__init__(model, config)
        self.rng = np.random.default_rng(config.seed)
        self.settings = config.penalty_settings(model.min_separation)
        self.candidates = candidate_grid(model, config.grid_size)
        self.estimator = config.make_estimator(
            model.sensor, self._observations_needed(model), self.rng
        )
        self._refiner = self._build_refiner() if config.refine else None
        self._utility_seconds = 0.0
        self._threads = BlasThreads()

    def _build_refiner(self) -> GridRefiner | None:
        """The refiner of continuous actions on a tensor candidate grid (else ``None``)."""
        if self.model.action_type != "continuous":
            return None
        low, high = self.model.control_low, self.model.control_high
        dim = low.shape[0]
        per_axis = round(self.candidates.shape[0] ** (1.0 / dim))
        if dim > 2 or per_axis**dim != self.candidates.shape[0] or per_axis < 2:
            return None
        axes = [np.linspace(lo, hi, per_axis) for lo, hi in zip(low, high, strict=True)]
        points = self.config.refine_points
        if points is None:
            points = 33 if dim == 1 else 17
        return GridRefiner(axes, points)

    def _observations_needed(self, model: EnvModel) -> int:
        """Largest ``k`` the planner's utility evaluates jointly."""
        return self.observations_per_term

    # -- helpers for subclasses
    def _timed(self, function: Any, *args: Any, **kwargs: Any) -> FloatArray:
        start = time.perf_counter()
        try:
            return np.asarray(function(*args, **kwargs), dtype=np.float64)
        finally:
            self._utility_seconds += time.perf_counter() - start

    def _single(self, belief: BeliefMI, poses: FloatArray) -> FloatArray:
        """``(K,)`` single-observation MIs on ``belief`` (eq. 20)."""
        return self._timed(belief.single, poses)

    def _singles(self, beliefs: list[BeliefMI], poses: list[FloatArray]) -> list[FloatArray]:
        """Every vehicle's ``(K,)`` single-observation MIs on its own belief (eq. 20), evaluated
        together (:func:`~infoseek.planners.information.base.single_many`)."""
        start = time.perf_counter()
        try:
            return single_many(beliefs, poses)
        finally:
            self._utility_seconds += time.perf_counter() - start

    def _pairs(self, belief: BeliefMI, poses: FloatArray, others: FloatArray) -> FloatArray:
        """``(K, M)`` pair MIs on ``belief``; per-pose work is cached in ``belief``."""
        return self._timed(belief.pairs, poses, others)

    def _tracks(self, states: FloatArray, controls: FloatArray) -> FloatArray:
        """``(A, C, H, 2)`` positions over the safety horizon of ``(A, state_dim)`` vehicles,
        each of the ``(C, control_dim)`` controls held (one vehicle-model call per step)."""
        vehicle = self.model.vehicle
        n_vehicles, n_controls = states.shape[0], controls.shape[0]
        current = np.repeat(states, n_controls, axis=0)
        held = np.tile(controls, (n_vehicles, 1))
        steps = []
        for _ in range(self.config.safety_horizon):
            current = vehicle.step(current, held, self.model.dt)
            steps.append(np.asarray(vehicle.position(current), dtype=np.float64))
        return np.stack(steps, axis=1).reshape(n_vehicles, n_controls, -1, 2)

    def _next_positions(self, state: FloatArray, controls: FloatArray) -> FloatArray:
        vehicle = self.model.vehicle
        nxt = vehicle.step(
            np.broadcast_to(state, (controls.shape[0], state.shape[0])), controls, self.model.dt
        )
        return np.asarray(vehicle.position(nxt), dtype=np.float64)

    def _beliefs(self, agents: list[str], infos: Mapping[str, Any]) -> list[BeliefMI]:
        """Each agent's own belief, subsampled to the planning particles and bound to the
        estimator (a :class:`BeliefMI` that caches per-pose work for this step)."""
        return [
            self.estimator.bind(planning.particles, planning.weights)
            for planning in planning_beliefs(agents, infos, self.config.n_planning, self.rng)
        ]

    # -- subclass hooks
    def _utility_function(
        self,
        beliefs: list[BeliefMI],
        positions: list[FloatArray],
        singles: list[FloatArray],
    ) -> UtilityFunction:
        """``utility(i, plans) -> (C,)`` for the coordination."""
        raise NotImplementedError

    def _initial_indices(self, singles: list[FloatArray]) -> NDArray[np.int64]:
        return np.array([int(np.argmax(s)) for s in singles], dtype=np.int64)

    # -- the step
    def _plan(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        with self._threads.limited():
            return self._decide(agents, states, infos)

    def _decide(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        """One decision (the class docstring's steps 1-7)."""
        start = time.perf_counter()
        self._utility_seconds = 0.0
        if len(agents) < self.min_agents:
            raise ValueError(
                f"{type(self).__name__} needs at least {self.min_agents} active agents, got "
                f"{len(agents)}"
            )
        rows = [self.model.agent_index(agent) for agent in agents]
        beliefs = self._beliefs(agents, infos)
        tracks = list(self._tracks(states[rows], self.candidates))
        positions = [track[:, 0, :] for track in tracks]
        singles = self._singles(beliefs, positions)
        utility = self._utility_function(beliefs, positions, singles)
        result = coordinate(
            [self.candidates] * len(agents),
            tracks,
            utility,
            self.settings,
            initial_indices=self._initial_indices(singles),
        )
        controls = result.controls.copy()
        refined = self._refiner is not None
        if refined:
            controls = self._refine(rows, result, utility, tracks)
        actions = controls_to_actions(self.model, agents, controls)
        self.last_plan = PlanDiagnostics.from_coordination(
            agents,
            controls,
            result,
            refined=refined,
            planning_time=time.perf_counter() - start,
            utility_time=self._utility_seconds,
        )
        return actions

    def _refine(
        self,
        rows: list[int],
        result: CoordinationResult,
        utility: UtilityFunction,
        candidate_tracks: list[FloatArray],
    ) -> FloatArray:
        """Polish each vehicle's grid control inside its grid cell, in Gauss-Seidel order
        (:class:`~infoseek.planners.refinement.GridRefiner`): the utility over the whole grid
        against the partners' final plans is ``utility(i, plans)`` (already computed by the
        coordination, so no further MI), penalised against the other vehicles' latest tracks
        with the coordination's last penalty weight."""
        assert self._refiner is not None
        controls = result.controls.copy()
        tracks = np.stack([candidate_tracks[i][result.indices[i]] for i in range(len(rows))])
        settings = self.settings
        for i in range(len(rows)):
            values = np.asarray(utility(i, result.indices.copy()), dtype=np.float64)
            controls[i], tracks[i] = self._refiner.refine(
                int(result.indices[i]),
                values,
                candidate_tracks[i],
                np.delete(tracks, i, axis=0),
                settings.min_separation,
                settings.gamma,
                1.0 / result.beta,
            )
        return controls
