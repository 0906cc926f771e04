"""Shared plumbing of the scripted policies: the planner interface and its helpers.

Every policy in :mod:`infoseek.planners` is used the same way inside the ordinary PettingZoo
parallel loop::

    planner = PairwiseNodePlanner.from_env(env, seed=0)
    observations, infos = env.reset(seed=0)
    while env.agents:
        actions = planner.act(observations, infos)
        observations, rewards, terminations, truncations, infos = env.step(actions)

``from_env`` copies the *a-priori* models (sensor, vehicle, target space, time step, separation,
action type and discrete control table) from ``env.unwrapped`` into an :class:`EnvModel`; the
planner never keeps the environment and never reads the true target. ``act`` reads, for every
agent present in ``observations``, its own belief ``infos[agent]["belief"]`` and the vehicle
states ``infos[agent]["vehicle_states"]`` (rows in ``possible_agents`` order), and returns one
action per agent inside ``env.action_space(agent)``.

Helpers shared by the planners: option parsing into frozen config dataclasses (unknown options
raise ``ValueError`` listing the valid ones), candidate-control grids, and the mapping from
controls to actions (continuous: the control itself as ``float32``, clipped into the Box;
discrete: the index of the nearest row of ``discrete_controls`` in control units scaled by the
control range).
"""

from __future__ import annotations

import dataclasses
import time
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.envs.targets import TargetSpace
from infoseek.envs.vehicles.base import Vehicle
from infoseek.planners.coordination import (
    CoordinationResult,
    PenaltySettings,
    UtilityFunction,
    coordinate,
)
from infoseek.planners.information import METHODS, BeliefMI, MIEstimator, make_estimator
from infoseek.planners.refinement import GridRefiner
from infoseek.planners.utilities import subsample_particles

FloatArray = NDArray[np.float64]

__all__ = [
    "EnvModel",
    "InformationPlanner",
    "PlanDiagnostics",
    "Planner",
    "PlannerConfig",
    "Policy",
    "candidate_grid",
    "controls_to_actions",
    "nearest_discrete_action",
    "parse_options",
    "read_states",
]


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
        missing = [
            name
            for name in (
                "sensor",
                "vehicle",
                "space",
                "dt",
                "min_separation",
                "action_type",
                "discrete_controls",
                "possible_agents",
            )
            if not hasattr(base, name)
        ]
        if missing:
            raise TypeError(
                f"env: expected an infoseek InformationSeekingEnv, missing attributes {missing}"
            )
        agents = tuple(base.possible_agents)
        discrete = base.discrete_controls
        if base.action_type not in ("continuous", "discrete"):
            raise ValueError(f"env.action_type must be continuous|discrete, got {base.action_type}")
        if base.action_type == "discrete" and discrete is None:
            raise ValueError("env: discrete action type without discrete_controls")
        return cls(
            sensor=getattr(base, "filter_sensor", base.sensor),
            vehicle=base.vehicle,
            space=base.space,
            dt=float(base.dt),
            min_separation=float(base.min_separation),
            action_type=str(base.action_type),
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


def parse_options(config_class: type, options: Mapping[str, Any]) -> Any:
    """Build a frozen config dataclass from keyword options.

    Raises:
        ValueError: An option that is not a field of ``config_class`` (the message lists the
            valid ones).
    """
    valid = [f.name for f in dataclasses.fields(config_class)]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ValueError(
            f"unknown option(s) {unknown} for {config_class.__name__}; valid options: {valid}"
        )
    return config_class(**options)


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
    if not np.all(np.isfinite(controls)):
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
    if not np.all(np.isfinite(states)):
        raise ValueError(f"infos[{agent!r}]['vehicle_states'] contains non-finite values")
    return states


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
                information planners) and ``"vehicle_states"``.

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


# --------------------------------------------------------------------------- information planners
@dataclass(frozen=True)
class PlannerConfig:
    """Options of the mutual-information planners (every field has a documented default).

    Attributes:
        n_planning: Planning particles per vehicle (2000): each vehicle's own belief is
            reduced to at most this many equally weighted particles by systematic resampling
            with the planner's generator.
        seed: Seed of the planner's own generator (None: OS entropy).
        mi_method: Mutual-information estimator (a name in
            :data:`infoseek.planners.information.ESTIMATORS`, or ``"auto"``: ``"fft"`` for
            additive-noise sensors, ``"fourier"`` for the beacon). ``"monte_carlo"`` draws from
            the planner's generator.
        quadrature_points: Observation grid size ``n_points`` of the estimator (None: the
            estimator's default).
        grid_size: Candidate controls per control axis for continuous actions (None: 9 for a
            1-D control, 5 per axis for 2-D); discrete actions always use the env's table.
        alpha: Penalty update ``beta := alpha beta`` (0.5).
        beta: Initial penalty parameter (1.0).
        gamma: Penalty exponent of eq. 27 (2.0).
        max_iterations: Maximum coordination sweeps (20).
        tolerance: Plan-change tolerance in control units (1e-6).
        feasibility_tolerance: Accepted planned-separation shortfall at convergence (0.05 units).
        schedule: ``"gauss-seidel"`` (default, sequential) or ``"jacobi"`` (synchronous).
        agreement_weight: Jacobi agreement/proximal weight (0.1; see
            :mod:`infoseek.planners.coordination`).
        reciprocal: Jacobi reciprocal anticipation of partner moves (True).
        separation_margin: Planning separation is ``min_separation + separation_margin``
            (0.25 units), so that the inexact penalty's residual shortfall stays clear of the
            environment's constraint.
        refine: Continuous actions only: polish each vehicle's grid choice inside its grid cell
            on a cubic spline of the utility through the candidate grid (values the
            coordination already computed; no further MI), see
            :mod:`infoseek.planners.refinement` (True).
        refine_points: Search points per control axis in the cell (odd, >= 3; None: 33 for a
            one-dimensional control, 17 per axis for two).
        safety_horizon: Steps ``H`` over which the separation constraints (eq. 28) are imposed,
            each candidate's track predicted with its control held (3). ``H = 1`` is the
            paper's one-step constraint; fixed-speed airplanes closing at up to twice their
            speed cannot always turn away within one step, so the default looks 3 steps ahead.
            The utility is always the one-step MI.
        max_joint_agents: :class:`JointPlanner` only: largest team size (3; the exact joint MI
            is evaluated on an observation grid, which the MI module supports for <= 3
            observations).
        max_exhaustive: :class:`JointPlanner` only: largest number of joint candidate
            combinations searched exhaustively (81: e.g. 9 turn rates for 2 airplanes); above
            it, coordinate ascent.
    """

    n_planning: int = 2000
    seed: int | None = None
    mi_method: str = "auto"
    quadrature_points: int | None = None
    grid_size: int | None = None
    alpha: float = 0.5
    beta: float = 1.0
    gamma: float = 2.0
    max_iterations: int = 20
    tolerance: float = 1e-6
    feasibility_tolerance: float = 0.05
    schedule: str = "gauss-seidel"
    agreement_weight: float = 0.1
    reciprocal: bool = True
    separation_margin: float = 0.25
    refine: bool = True
    refine_points: int | None = None
    safety_horizon: int = 3
    max_joint_agents: int = 3
    max_exhaustive: int = 81

    def __post_init__(self) -> None:
        for name in (
            "n_planning",
            "safety_horizon",
            "max_joint_agents",
            "max_exhaustive",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if self.quadrature_points is not None and self.quadrature_points < 2:
            raise ValueError(
                f"quadrature_points must be None or >= 2, got {self.quadrature_points}"
            )
        if not isinstance(self.mi_method, str) or self.mi_method not in METHODS:
            raise ValueError(f"mi_method must be one of {list(METHODS)}, got {self.mi_method!r}")
        if self.refine_points is not None and (
            isinstance(self.refine_points, bool)
            or not isinstance(self.refine_points, int | np.integer)
            or self.refine_points < 3
        ):
            raise ValueError(
                f"refine_points must be None or an integer >= 3, got {self.refine_points!r}"
            )
        if self.grid_size is not None and self.grid_size < 2:
            raise ValueError(f"grid_size must be None or >= 2, got {self.grid_size}")
        if not (np.isfinite(self.separation_margin) and self.separation_margin >= 0):
            raise ValueError(f"separation_margin must be >= 0, got {self.separation_margin}")
        if not isinstance(self.refine, bool):
            raise TypeError(f"refine must be a bool, got {self.refine!r}")
        # Validate the penalty parameters once (raises ValueError naming the field).
        self.penalty_settings(1.0)

    def penalty_settings(self, min_separation: float) -> PenaltySettings:
        """The coordination settings for an environment's ``min_separation``."""
        return PenaltySettings(
            min_separation=min_separation + self.separation_margin,
            alpha=self.alpha,
            beta=self.beta,
            gamma=self.gamma,
            max_iterations=self.max_iterations,
            tolerance=self.tolerance,
            feasibility_tolerance=self.feasibility_tolerance,
            schedule=self.schedule,  # type: ignore[arg-type]
            agreement_weight=self.agreement_weight,
            reciprocal=self.reciprocal,
        )

    def make_estimator(
        self, sensor: Sensor, n_observations: int, rng: np.random.Generator
    ) -> MIEstimator:
        """The planner's MI estimator for ``sensor`` (``rng`` feeds ``"monte_carlo"``).

        Raises:
            TypeError: ``mi_method`` needs a sensor method the sensor lacks.
        """
        return make_estimator(
            self.mi_method,
            sensor,
            n_observations=n_observations,
            n_points=self.quadrature_points,
            rng=rng,
        )


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
        beliefs = []
        for agent in agents:
            info = infos[agent]
            if "belief" not in info:
                raise ValueError(f"infos[{agent!r}] must contain 'belief'")
            planning = subsample_particles(info["belief"], self.config.n_planning, self.rng)
            beliefs.append(self.estimator.bind(planning.particles, planning.weights))
        return beliefs

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
        singles = [self._single(b, p) for b, p in zip(beliefs, positions, strict=True)]
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
        diagnostics = PlanDiagnostics(
            agents=tuple(agents),
            controls=controls,
            grid_controls=result.controls,
            utilities=result.utilities,
            iterations=result.iterations,
            converged=result.converged,
            max_violation=result.max_violation,
            agreement_residual=result.agreement_residual,
            beta=result.beta,
            refined=refined,
            planning_time=0.0,
            utility_time=0.0,
        )
        actions = controls_to_actions(self.model, agents, controls)
        self.last_plan = dataclasses.replace(
            diagnostics,
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
