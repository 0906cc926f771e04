r"""The generic multi-vehicle information-seeking environment (Hoffmann, Waslander & Tomlin 2006).

:class:`InformationSeekingEnv` is a PettingZoo :class:`~pettingzoo.ParallelEnv` in which ``A``
vehicles ("vehicle_0" ... "vehicle_{A-1}") carry identical sensors and search a domain
:math:`\Theta` for one target :math:`\theta`. The versioned environments
(:mod:`infoseek.envs.bearings_v0`, :mod:`infoseek.envs.beacon_v0`) only choose the components
and the defaults; everything else lives here.

Model (section II of the paper):

* vehicle dynamics :math:`x^{(i)}_{t+1} = f(x^{(i)}_t, u^{(i)}_t)` (eq. 1), one
  :class:`~infoseek.envs.vehicles.base.Vehicle` model shared by all agents;
* separation constraint :math:`\|x^{(i)}_t - x^{(j)}_t\| \ge \bar d` (eq. 2), enforced softly
  through a reward penalty (``separation_penalty`` per violated pair per step);
* measurement :math:`z^{(i)}_t = h(x^{(i)}_t, \theta, \eta^{(i)}_t)` (eq. 3), one
  :class:`~infoseek.envs.sensors.base.Sensor` shared by all agents;
* every agent ``i`` keeps its *own* particle-filter belief :math:`p_t(\theta^{(i)})`
  (eq. 11), updated by Bayes' rule with the product of the likelihoods of every observation it
  received this step (eq. 4 and the conditional-independence expansion of eq. 14);
* the MMSE estimate :math:`\hat\theta^{(i)}_t` (eq. 12) and the entropy
  :math:`H(\theta^{(i)}_t)` (eq. 6) are those of agent ``i``'s own belief.

Step order (binding, see the project contract):

1. validate the actions (shape, finiteness, range), clip continuous controls to the vehicle's
   bounds;
2. every vehicle steps (eq. 1);
3. the target moves (its motion model; stationary by default);
4. every vehicle observes the target (eq. 3) with the environment's observation-noise stream;
5. agent ``i`` receives its own observation always, and agent ``j``'s observation when
   ``||x_i - x_j|| <= comm_range`` and the message is not lost (independently with probability
   ``message_loss``); by default (``comm_range=inf``, ``message_loss=0``) everyone receives
   everything, as in the paper;
6. belief ``i``: ``predict(dt)``, ``update`` with the received observations,
   ``resample_if_needed()``;
7. rewards, observations and infos.

Filter noise floor (``filter_max_snr``). The beliefs may evaluate the observations with a
deliberately *wider* likelihood than the one that generates them, a standard "noise inflation"
for particle filters whose sensor is far more precise than the particle spacing. With a cap
``c``, a sensor that offers ``with_max_snr`` (the beacon receiver) is replaced, in every belief
update, by ``sensor.with_max_snr(c)``: the receiver whose noise is inflated wherever the
signal-to-noise ratio ``rho = |H| / noise_std`` exceeds ``c``, so no single reading's peak is
narrower than ``~1/c`` rad. That model is the attribute :attr:`filter_sensor`; the planners
read it (``EnvModel.from_env``), so they score candidates with exactly the likelihood the
beliefs apply. Near an avalanche
beacon ``rho ~ moment / r^3`` reaches ``10^3`` within a few units, and the exact posterior after
one step of four readings is a blob of a few hundredths of a unit: a 2000-particle filter
almost never has a particle inside it, so the particles far away (flat likelihood ``~1/pi``)
take the mass and the estimate jumps away from a correct fix (measured: 2 of 20 seeded
4-agent ``beacon_v0`` episodes localised with the exact likelihood, and 8000 particles did not
help). The floor trades this unresolvable precision for a posterior the particles can
represent; the measurements themselves (:meth:`~InformationSeekingEnv.step` step 4) stay
exact. It is a deviation from the paper, which does not say how
its filter handled the near field. ``beacon_v0`` uses ``c = 5`` (angular std floor ~0.2 rad):
with the pairwise planner 36 of 40 seeded episodes then end with at least 0.9 of every agent's
mass within 1 unit of its estimate, each such estimate within 1 unit of the truth (``c = 20``:
12 of 20, ``c = 10``: 17 of 20, ``c = 3``: 17 of 20). ``None`` (the default here) evaluates the
exact likelihood.

Reward of agent ``i`` at step ``t``:

.. math::

    r^{(i)}_t = H(\theta^{(i)}_{t-1}) - H(\theta^{(i)}_t)
                - c \, \#\{j \ne i : \|x^{(i)}_t - x^{(j)}_t\| < \bar d\},

the reduction of the (histogram-estimated, :mod:`infoseek.envs.entropy`) entropy of its own
belief over the step minus ``c = separation_penalty`` times the number of separation
violations involving ``i``. Summed over an episode, the information part telescopes to
:math:`H_0 - H_T` (conservation).

Randomness: ``reset(seed)`` builds ``numpy.random.SeedSequence(seed)`` and spawns independent
streams, in this order: target (prior draw and motion), observation noise, message loss,
vehicle initial states, then one stream per agent's belief. ``reset(seed=None)`` after a seeded
reset spawns fresh children of the same sequence, so a run of resets is reproducible from the
first seed; a first reset without a seed uses OS entropy.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium
import numpy as np
from numpy.typing import NDArray
from pettingzoo import ParallelEnv

from infoseek.envs.belief import BeliefView, ParticleBelief
from infoseek.envs.sensors import make_sensor
from infoseek.envs.sensors.base import Sensor
from infoseek.envs.spaces import observation_layout, position_box, state_layout
from infoseek.envs.targets import TargetMotion, TargetSpace, make_target_motion
from infoseek.envs.vehicles import make_vehicle
from infoseek.envs.vehicles.base import Vehicle

FloatArray = NDArray[np.float64]
ObsArray = NDArray[np.float32]

ACTION_TYPES = ("continuous", "discrete")
#: Fewest particles per belief: fewer cannot represent the uniform prior (a 40 x 40 domain
#: sampled by 100 particles already leaves ~4 units between neighbours), and the posterior-mass
#: and localisation metrics of a belief of a handful of particles are meaningless.
MIN_PARTICLES = 100
RENDER_MODES = (None, "rgb_array", "human")
#: Keys of ``infos[agent]`` (at ``reset`` and at every ``step``); with ``belief_in_infos=True``
#: also ``"belief"``.
INFO_KEYS = (
    "vehicle_states",
    "agent_index",
    "belief_recovered",
    "ess",
    "entropy",
    "posterior_mass",
    "separation_violations",
)


# ----------------------------------------------------------------------------- validation helpers
def _check_int(value: object, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer >= {minimum}, got {value!r}")
    if int(value) < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)


def _check_float(
    value: object,
    name: str,
    *,
    low: float = -math.inf,
    high: float = math.inf,
    low_open: bool = False,
    allow_inf: bool = False,
) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    number = float(value)
    bound = f"{'(' if low_open else '['}{low}, {high}]"
    if math.isnan(number) or (math.isinf(number) and not allow_inf):
        raise ValueError(f"{name} must be a finite number in {bound}, got {number}")
    if number < low or number > high or (low_open and number == low):
        raise ValueError(f"{name} must lie in {bound}, got {number}")
    return number


def _check_kwargs(value: object, name: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise TypeError(f"{name} must be a dict of keyword arguments or None, got {value!r}")
    return dict(value)


def _readonly(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def clustered_start_positions(n_agents: int, center: Sequence[float], spacing: float) -> FloatArray:
    """Positions of a compact square-ish grid of vehicles (the paper's close initial cluster).

    Args:
        n_agents: Number of vehicles ``A``.
        center: ``(2,)`` centre of the cluster.
        spacing: Distance between grid neighbours.

    Returns:
        ``(A, 2)`` positions, row-major on a ``ceil(sqrt(A))``-column grid centred on ``center``.
    """
    n_cols = math.ceil(math.sqrt(n_agents))
    n_rows = math.ceil(n_agents / n_cols)
    index = np.arange(n_agents)
    cols = index % n_cols - (n_cols - 1) / 2.0
    rows = index // n_cols - (n_rows - 1) / 2.0
    return np.asarray(center, dtype=np.float64) + spacing * np.stack([cols, rows], axis=-1)


def pairwise_distances(positions: FloatArray) -> FloatArray:
    """``(A, A)`` Euclidean distances between ``(A, 2)`` positions."""
    diff = positions[:, None, :] - positions[None, :, :]
    return np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))


def separation_violations(positions: FloatArray, min_separation: float) -> NDArray[np.int64]:
    """Per-agent count of violated pairs of eq. 2 (distance strictly below ``min_separation``).

    Args:
        positions: ``(A, 2)`` vehicle positions.
        min_separation: The minimum separation :math:`\\bar d`.

    Returns:
        ``(A,)`` number of other vehicles closer than ``min_separation`` to each vehicle.
    """
    close = pairwise_distances(positions) < min_separation
    np.fill_diagonal(close, False)
    return close.sum(axis=1).astype(np.int64)


class InformationSeekingEnv(ParallelEnv):
    """Parallel PettingZoo environment: a team of vehicles searching for one target.

    Every argument is keyword-only; an unknown keyword raises ``ValueError`` listing the valid
    ones. The versioned modules document their defaults in their manuals.

    Args:
        sensor: Sensor registry name (``"bearing"``, ``"beacon"``, ``"range"``) or instance.
        sensor_kwargs: Constructor arguments when ``sensor`` is a name (e.g. ``{"sigma": 0.1}``).
        vehicle: Vehicle registry name (``"airplane"``, ``"quadrotor"``) or instance.
        vehicle_kwargs: Constructor arguments when ``vehicle`` is a name.
        target_space: A :class:`TargetSpace`, ``"planar"``, ``"planar_with_orientation"`` or
            ``None`` (chosen from the sensor's ``target_dim``: 2 -> planar, 3 -> planar with
            orientation). Its ``dim`` must equal the sensor's ``target_dim``.
        domain_size: ``(width, height)`` of the search domain in distance units, used when the
            space is built by name (default ``(40, 40)``); must be ``None`` with an instance.
        target_motion: Target motion registry name (``"stationary"``, ``"random_walk"``) or
            instance; the same model is used by every agent's belief ``predict``.
        target_motion_kwargs: Constructor arguments when ``target_motion`` is a name.
        n_agents: Number of vehicles ``A >= 1``.
        n_particles: Particles per agent belief, ``N >= MIN_PARTICLES`` (100).
        max_cycles: Steps before truncation (>= 1). May be reassigned between episodes.
        dt: Time step in seconds (> 0).
        min_separation: :math:`\\bar d` of eq. 2 in distance units (>= 0).
        start_center: ``(2,)`` centre of the initial cluster.
        start_spacing: Grid spacing of the initial cluster; ``None`` means
            ``max(2.0, 2 * min_separation)``. Must exceed ``min_separation``.
        start_positions: Explicit ``(A, 2)`` initial positions (overrides the cluster); every
            pair must be at least ``min_separation`` apart and inside the domain.
        action_type: ``"continuous"`` (a Box of the vehicle's control bounds; values outside are
            clipped) or ``"discrete"`` (``Discrete(k**control_dim)`` over the grid
            :attr:`discrete_controls`).
        n_discrete_actions: ``k >= 2`` evenly spaced controls per control axis (discrete only).
        separation_penalty: Reward subtracted per violated pair per step (>= 0).
        resample_threshold: Belief resampling threshold on ``ESS / N`` in ``[0, 1]``.
        roughening: Belief roughening factor (>= 0; 0 disables).
        tempering_ess: Belief progressive-correction floor in ``[0, 1)`` (0 disables; see
            :mod:`infoseek.envs.belief`).
        filter_max_snr: Filter noise floor (module docstring): ``None`` evaluates the exact
            likelihood; a float ``c > 0`` makes every belief update (and the planners) use
            ``sensor.with_max_snr(c)`` (the sensor must offer it). The model the beliefs use is
            the attribute ``filter_sensor`` (the sensor itself when ``None``).
        entropy_bins: Histogram grid of the belief entropy estimate (``None``: belief default).
        belief_grid: ``(gx, gy)`` coarse belief-mass grid in the observation.
        localization_radius: Radius (distance units, > 0) of the posterior-mass criterion.
        localization_mass: Mass within ``localization_radius`` of the MMSE estimate that counts
            as localised, in ``(0, 1]``.
        terminate_on_localization: Terminate every agent once *every* agent's belief is
            localised (``posterior_mass >= localization_mass``).
        comm_range: Distance up to which observations are shared (>= 0, ``inf`` = everywhere).
        message_loss: Probability in ``[0, 1]`` that a message between two agents is lost.
        belief_in_infos: Also put each agent's :class:`BeliefView` in ``infos[agent]["belief"]``
            (what the scripted planners read). Off by default, so that infos hold only numbers
            and numpy arrays (what RL frameworks can batch); :meth:`belief` returns the view
            either way.
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
        name: Environment name reported in ``metadata["name"]``.
    """

    metadata: dict[str, Any] = {
        "name": "information_seeking",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 4,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        *,
        sensor: str | Sensor = "bearing",
        sensor_kwargs: Mapping[str, Any] | None = None,
        vehicle: str | Vehicle = "airplane",
        vehicle_kwargs: Mapping[str, Any] | None = None,
        target_space: TargetSpace | str | None = None,
        domain_size: tuple[float, float] | None = None,
        target_motion: str | TargetMotion = "stationary",
        target_motion_kwargs: Mapping[str, Any] | None = None,
        n_agents: int = 4,
        n_particles: int = 2000,
        max_cycles: int = 60,
        dt: float = 1.0,
        min_separation: float = 1.0,
        start_center: tuple[float, float] = (5.0, 5.0),
        start_spacing: float | None = None,
        start_positions: Sequence[Sequence[float]] | FloatArray | None = None,
        action_type: str = "continuous",
        n_discrete_actions: int = 5,
        separation_penalty: float = 1.0,
        resample_threshold: float = 1.0,
        roughening: float = 0.2,
        tempering_ess: float = 0.1,
        filter_max_snr: float | None = None,
        entropy_bins: tuple[int, ...] | None = None,
        belief_grid: tuple[int, int] = (8, 8),
        localization_radius: float = 1.0,
        localization_mass: float = 0.9,
        terminate_on_localization: bool = False,
        comm_range: float = math.inf,
        message_loss: float = 0.0,
        belief_in_infos: bool = False,
        render_mode: str | None = None,
        name: str = "information_seeking",
        **unknown: Any,
    ) -> None:
        if unknown:
            valid = sorted(self.config_keys())
            raise ValueError(
                f"unknown configuration key(s) {sorted(unknown)}; valid keys are {valid}"
            )

        # ---- components
        self.sensor: Sensor = make_sensor(sensor, **_check_kwargs(sensor_kwargs, "sensor_kwargs"))
        self.vehicle: Vehicle = make_vehicle(
            vehicle, **_check_kwargs(vehicle_kwargs, "vehicle_kwargs")
        )
        self.target_motion: TargetMotion = make_target_motion(
            target_motion, **_check_kwargs(target_motion_kwargs, "target_motion_kwargs")
        )
        self.space: TargetSpace = self._build_space(target_space, domain_size)
        if self.sensor.target_dim != self.space.dim:
            raise ValueError(
                f"target_space has dim {self.space.dim} but sensor {self.sensor.name!r} expects "
                f"targets of dim {self.sensor.target_dim}"
            )

        # ---- scalars
        self.n_agents = _check_int(n_agents, "n_agents", 1)
        self.n_particles = _check_int(n_particles, "n_particles", MIN_PARTICLES)
        self._max_cycles = _check_int(max_cycles, "max_cycles", 1)
        self.dt = _check_float(dt, "dt", low=0.0, low_open=True)
        self.min_separation = _check_float(min_separation, "min_separation", low=0.0)
        self.separation_penalty = _check_float(separation_penalty, "separation_penalty", low=0.0)
        self.resample_threshold = _check_float(
            resample_threshold, "resample_threshold", low=0.0, high=1.0
        )
        self.roughening = _check_float(roughening, "roughening", low=0.0)
        self.tempering_ess = _check_float(tempering_ess, "tempering_ess", low=0.0, high=1.0)
        if self.tempering_ess >= 1.0:
            raise ValueError(f"tempering_ess must be in [0, 1), got {tempering_ess!r}")
        # the likelihood model every belief update uses: the sensor, or its noise-floored view
        if filter_max_snr is None:
            self.filter_max_snr: float | None = None
            self.filter_sensor: Sensor = self.sensor
        else:
            self.filter_max_snr = _check_float(
                filter_max_snr, "filter_max_snr", low=0.0, low_open=True
            )
            if not callable(getattr(self.sensor, "with_max_snr", None)):
                raise ValueError(
                    f"filter_max_snr needs a sensor that offers with_max_snr (e.g. 'beacon'); "
                    f"sensor {self.sensor.name!r} does not: use filter_max_snr=None"
                )
            self.filter_sensor = self.sensor.with_max_snr(  # type: ignore[attr-defined]
                self.filter_max_snr
            )
        self.localization_radius = _check_float(
            localization_radius, "localization_radius", low=0.0, low_open=True
        )
        self.localization_mass = _check_float(
            localization_mass, "localization_mass", low=0.0, high=1.0, low_open=True
        )
        if not isinstance(terminate_on_localization, bool | np.bool_):
            raise TypeError(
                f"terminate_on_localization must be a bool, got {terminate_on_localization!r}"
            )
        self.terminate_on_localization = bool(terminate_on_localization)
        self.comm_range = _check_float(comm_range, "comm_range", low=0.0, allow_inf=True)
        self.message_loss = _check_float(message_loss, "message_loss", low=0.0, high=1.0)
        self.entropy_bins = None if entropy_bins is None else tuple(entropy_bins)
        if (
            not isinstance(belief_grid, Sequence)
            or len(belief_grid) != 2
            or any(isinstance(g, bool) or not isinstance(g, int | np.integer) for g in belief_grid)
            or min(belief_grid) < 1
        ):
            raise ValueError(f"belief_grid must be two integers >= 1, got {belief_grid!r}")
        self.belief_grid = (int(belief_grid[0]), int(belief_grid[1]))
        if render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
        self.render_mode = render_mode
        if not isinstance(belief_in_infos, bool | np.bool_):
            raise TypeError(f"belief_in_infos must be True or False, got {belief_in_infos!r}")
        self.belief_in_infos = bool(belief_in_infos)
        self.metadata = {**type(self).metadata, "name": str(name)}

        # ---- agents and start positions
        self.possible_agents = [f"vehicle_{i}" for i in range(self.n_agents)]
        self.agents: list[str] = []
        self.agent_name_mapping = {agent: i for i, agent in enumerate(self.possible_agents)}
        self.start_positions = _readonly(
            self._build_start_positions(start_center, start_spacing, start_positions)
        )

        # ---- actions
        if action_type not in ACTION_TYPES:
            raise ValueError(f"action_type must be one of {ACTION_TYPES}, got {action_type!r}")
        self.action_type = action_type
        self.control_low = np.asarray(self.vehicle.control_low, dtype=np.float64)
        self.control_high = np.asarray(self.vehicle.control_high, dtype=np.float64)
        control_dim = int(self.vehicle.control_dim)
        if action_type == "discrete":
            self.n_discrete_actions = _check_int(n_discrete_actions, "n_discrete_actions", 2)
            axes = [
                np.linspace(lo, hi, self.n_discrete_actions)
                for lo, hi in zip(self.control_low, self.control_high, strict=True)
            ]
            grid = np.meshgrid(*axes, indexing="ij")
            self.discrete_controls: FloatArray | None = _readonly(
                np.stack([g.ravel() for g in grid], axis=-1)
            )
            self._action_spaces: dict[str, gymnasium.spaces.Space] = {
                agent: gymnasium.spaces.Discrete(len(self.discrete_controls))
                for agent in self.possible_agents
            }
        else:
            self.n_discrete_actions = _check_int(n_discrete_actions, "n_discrete_actions", 2)
            self.discrete_controls = None
            self._action_spaces = {
                agent: gymnasium.spaces.Box(
                    low=self.control_low.astype(np.float32),
                    high=self.control_high.astype(np.float32),
                    shape=(control_dim,),
                    dtype=np.float32,
                )
                for agent in self.possible_agents
            }

        # ---- observations and centralised state
        self._build_spaces()

        # ---- episode state (filled by reset)
        self._seed_sequence: np.random.SeedSequence | None = None
        self._target: FloatArray | None = None
        self._states: FloatArray | None = None
        self._beliefs: list[ParticleBelief] = []
        self._state: ObsArray | None = None
        self._entropies = np.zeros(self.n_agents)
        self._cycles = 0
        self.last_measurements: FloatArray | None = None
        self.last_reception: NDArray[np.bool_] | None = None
        self._trails: list[FloatArray] = []
        self._renderer: Any = None

    # ----------------------------------------------------------------------------- construction
    @classmethod
    def config_keys(cls) -> tuple[str, ...]:
        """Names of every accepted configuration keyword."""
        parameters = inspect.signature(cls.__init__).parameters.values()
        return tuple(p.name for p in parameters if p.kind is inspect.Parameter.KEYWORD_ONLY)

    def _build_space(
        self, target_space: TargetSpace | str | None, domain_size: tuple[float, float] | None
    ) -> TargetSpace:
        if isinstance(target_space, TargetSpace):
            if domain_size is not None:
                raise ValueError("domain_size must be None when target_space is a TargetSpace")
            return target_space
        size = (40.0, 40.0) if domain_size is None else domain_size
        if target_space is None:
            target_space = {2: "planar", 3: "planar_with_orientation"}.get(
                int(self.sensor.target_dim), ""
            )
            if not target_space:
                raise ValueError(
                    f"no default target_space for sensor target_dim {self.sensor.target_dim}; "
                    "pass a TargetSpace"
                )
        if target_space == "planar":
            return TargetSpace.planar((float(size[0]), float(size[1])))
        if target_space == "planar_with_orientation":
            return TargetSpace.planar_with_orientation((float(size[0]), float(size[1])))
        raise ValueError(
            "target_space must be a TargetSpace, 'planar', 'planar_with_orientation' or None, "
            f"got {target_space!r}"
        )

    def _build_start_positions(
        self,
        start_center: Sequence[float],
        start_spacing: float | None,
        start_positions: Sequence[Sequence[float]] | FloatArray | None,
    ) -> FloatArray:
        low = np.asarray(self.space.low, dtype=np.float64)[:2]
        high = np.asarray(self.space.high, dtype=np.float64)[:2]
        if start_positions is not None:
            positions = np.array(start_positions, dtype=np.float64)
            if positions.shape != (self.n_agents, 2) or not np.all(np.isfinite(positions)):
                raise ValueError(
                    f"start_positions must be a finite ({self.n_agents}, 2) array (one row per "
                    f"agent), got shape {positions.shape}"
                )
        else:
            center = np.asarray(start_center, dtype=np.float64)
            if center.shape != (2,) or not np.all(np.isfinite(center)):
                raise ValueError(f"start_center must be a finite (x, y) pair, got {start_center!r}")
            if start_spacing is None:
                spacing = max(2.0, 2.0 * self.min_separation)
            else:
                spacing = _check_float(start_spacing, "start_spacing", low=0.0, low_open=True)
            if self.n_agents > 1 and spacing <= self.min_separation:
                raise ValueError(
                    f"start_spacing must exceed min_separation={self.min_separation}, got {spacing}"
                )
            positions = clustered_start_positions(self.n_agents, tuple(center.tolist()), spacing)
            # shift (never rescale) the cluster into the domain when it pokes out
            extent = positions.max(axis=0) - positions.min(axis=0)
            if np.any(extent > high - low):
                raise ValueError(
                    f"a cluster of {self.n_agents} vehicles with start_spacing={spacing} does "
                    f"not fit in the domain {tuple(high - low)}"
                )
            shift = np.maximum(low - positions.min(axis=0), 0.0) - np.maximum(
                positions.max(axis=0) - high, 0.0
            )
            positions = positions + shift
        outside = np.flatnonzero(np.any((positions < low) | (positions > high), axis=1))
        if outside.size:
            raise ValueError(
                f"start_positions of {self.possible_agents[outside[0]]} "
                f"{positions[outside[0]].tolist()} lie outside the domain "
                f"[{low.tolist()}, {high.tolist()}]"
            )
        distances = pairwise_distances(positions)
        np.fill_diagonal(distances, np.inf)
        i, j = np.unravel_index(np.argmin(distances), distances.shape)
        if self.n_agents > 1 and distances[i, j] < self.min_separation:
            raise ValueError(
                f"start positions of {self.possible_agents[i]} and {self.possible_agents[j]} are "
                f"{distances[i, j]:.3g} apart, closer than min_separation={self.min_separation}"
            )
        return positions

    def _build_spaces(self) -> None:
        """Observation and state layouts with finite bounds (:mod:`infoseek.envs.spaces`)."""
        max_speed = getattr(self.vehicle, "max_speed", None)
        if isinstance(max_speed, bool) or not isinstance(max_speed, int | float | np.floating):
            raise TypeError(
                f"vehicle {self.vehicle!r} must have a numeric max_speed attribute (it bounds "
                "the observed positions)"
            )
        box = position_box(
            self.space, np.asarray(self.start_positions), float(max_speed), self.dt, self.max_cycles
        )
        geometry = (
            self.vehicle.state_names,
            float(max_speed),
            box,
            self.space,
            self.n_agents,
            self.belief_grid,
        )
        self.observation_layout, obs_low, obs_high = observation_layout(*geometry)
        self._obs_low = obs_low.astype(np.float32)
        self._obs_high = obs_high.astype(np.float32)
        self._observation_spaces = {
            agent: gymnasium.spaces.Box(low=self._obs_low, high=self._obs_high, dtype=np.float32)
            for agent in self.possible_agents
        }
        self.state_layout, state_low, state_high = state_layout(*geometry)
        self._state_low = state_low.astype(np.float32)
        self._state_high = state_high.astype(np.float32)
        self.state_space = gymnasium.spaces.Box(
            low=self._state_low, high=self._state_high, dtype=np.float32
        )

    @property
    def max_cycles(self) -> int:
        """Steps before truncation. Reassigning it (between episodes) rebuilds the observation
        and state spaces, whose position bounds grow with the episode length."""
        return self._max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        self._max_cycles = _check_int(value, "max_cycles", 1)
        self._build_spaces()

    # ----------------------------------------------------------------------------- spaces
    @property
    def observation_spaces(self) -> dict[str, gymnasium.spaces.Box]:
        """Agent -> observation space, for every possible agent (PettingZoo convention)."""
        return dict(self._observation_spaces)

    @property
    def action_spaces(self) -> dict[str, gymnasium.spaces.Space]:
        """Agent -> action space, for every possible agent (PettingZoo convention)."""
        return dict(self._action_spaces)

    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        """The (shared-shape) flat float32 observation space of ``agent``."""
        return self._observation_spaces[self._agent_index(agent, "observation_space")]

    def action_space(self, agent: str) -> gymnasium.spaces.Space:
        """``Box`` of the vehicle's control bounds, or ``Discrete(k**control_dim)``."""
        return self._action_spaces[self._agent_index(agent, "action_space")]

    def _agent_index(self, agent: str, where: str) -> str:
        if agent not in self.agent_name_mapping:
            raise ValueError(f"{where}: unknown agent {agent!r}; agents are {self.possible_agents}")
        return agent

    # ----------------------------------------------------------------------------- episode
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, ObsArray], dict[str, dict[str, Any]]]:
        """Start an episode: draw the target from the prior, place the vehicles, reset beliefs.

        Args:
            seed: Root seed of every random stream (see the module docstring).
            options: ``None`` or a dict with the optional key ``"target"``: a ``(target_dim,)``
                true target state inside the domain, used instead of a draw from the prior
                (for reproducing a scenario, e.g. the paper's Fig. 2 beacon at orientation
                pi/4). The random streams are the same either way. Other keys are ignored
                with a ``UserWarning``.

        Returns:
            ``(observations, infos)`` keyed by agent.
        """
        if seed is not None or self._seed_sequence is None:
            self._seed_sequence = np.random.SeedSequence(seed)
        streams = [np.random.default_rng(s) for s in self._seed_sequence.spawn(4 + self.n_agents)]
        self._target_rng, self._obs_rng, self._message_rng, vehicle_rng = streams[:4]
        belief_rngs = streams[4:]

        self.agents = list(self.possible_agents)
        self._cycles = 0
        self._target = self.space.sample_uniform(1, self._target_rng)[0]
        if options:
            self._target = self._target_from_options(options)
        self._states = np.asarray(
            self.vehicle.initial_states(self.start_positions.copy(), vehicle_rng),
            dtype=np.float64,
        )
        self._beliefs = [
            ParticleBelief.from_prior(
                self.space,
                self.n_particles,
                rng,
                motion=self.target_motion,
                resample_threshold=self.resample_threshold,
                roughening=self.roughening,
                entropy_bins=self.entropy_bins,
                tempering_ess=self.tempering_ess,
            )
            for rng in belief_rngs
        ]
        self._entropies = np.array([b.entropy() for b in self._beliefs])
        self._recovered = np.zeros(self.n_agents, dtype=bool)
        self.last_measurements = None
        self.last_reception = None
        positions = self.vehicle.position(self._current_states())
        self._violations = separation_violations(positions, self.min_separation)
        self._trails = [positions.copy()] if self.render_mode is not None else []
        observations, infos = self._observe_all()
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def _target_from_options(self, options: Mapping[str, Any]) -> NDArray[np.float64]:
        unknown = sorted(set(options) - {"target"})
        if unknown:
            # PettingZoo's API tests pass arbitrary options; ignore them, but not silently.
            warnings.warn(
                f"reset options: ignoring unknown keys {unknown}; valid keys are ['target']",
                stacklevel=3,
            )
        if "target" not in options:
            return self._current_target()
        target = np.asarray(options["target"], dtype=np.float64)
        if target.shape != (self.space.dim,) or not np.all(np.isfinite(target)):
            raise ValueError(
                f"reset options['target'] must be {self.space.dim} finite numbers "
                f"{self.space.names}, got {options['target']!r}"
            )
        target = self.space.wrap(target[None])[0]
        if not bool(np.all(self.space.contains(target[None]))):
            raise ValueError(
                f"reset options['target'] {target.tolist()} lies outside the domain "
                f"[{self.space.low}, {self.space.high}]"
            )
        return target

    def step(
        self, actions: Mapping[str, Any]
    ) -> tuple[
        dict[str, ObsArray],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """Advance every vehicle, observe, share, update every belief (module docstring order).

        Args:
            actions: One action per live agent: a ``(control_dim,)`` array for continuous
                actions (clipped to the bounds), an integer in ``[0, K)`` for discrete ones.

        Returns:
            ``(observations, rewards, terminations, truncations, infos)`` keyed by agent.

        Raises:
            ValueError: unknown or missing agent, wrong shape, NaN/inf, out-of-range index.
            TypeError: a non-integer discrete action or non-mapping ``actions``.
        """
        if not self.agents:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        controls = self._controls_from_actions(actions)
        self._states = np.asarray(
            self.vehicle.step(self._current_states(), controls, self.dt), dtype=np.float64
        )
        self._target = self.target_motion.propagate(
            self._current_target()[None, :], self.space, self.dt, self._target_rng
        )[0]
        positions = self.vehicle.position(self._states)
        n = self.n_agents
        measurements = np.asarray(
            self.sensor.sample(
                positions, np.broadcast_to(self._target, (n, self.space.dim)), self._obs_rng
            ),
            dtype=np.float64,
        ).reshape(n, self.sensor.obs_dim)
        reception = self._reception(positions)
        self.last_measurements = _readonly(measurements.copy())
        self.last_reception = _readonly(reception)

        previous_entropies = self._entropies.copy()
        for i, belief in enumerate(self._beliefs):
            received = reception[i]
            belief.predict(self.dt)
            update = belief.update(self.filter_sensor, measurements[received], positions[received])
            self._recovered[i] = bool(update.recovered)
            belief.resample_if_needed()
            self._entropies[i] = belief.entropy()
        self._cycles += 1
        self._violations = separation_violations(positions, self.min_separation)
        if self.render_mode is not None:
            self._trails.append(positions.copy())

        observations, infos = self._observe_all()
        gains = previous_entropies - self._entropies
        rewards = {
            agent: float(gains[i] - self.separation_penalty * self._violations[i])
            for i, agent in enumerate(self.possible_agents)
        }
        localised = self.terminate_on_localization and all(
            info["posterior_mass"] >= self.localization_mass for info in infos.values()
        )
        truncated = self._cycles >= self.max_cycles
        terminations = dict.fromkeys(self.possible_agents, bool(localised))
        truncations = dict.fromkeys(self.possible_agents, bool(truncated and not localised))
        if localised or truncated:
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _controls_from_actions(self, actions: Mapping[str, Any]) -> FloatArray:
        if not isinstance(actions, Mapping):
            raise TypeError(f"actions must be a dict agent -> action, got {type(actions).__name__}")
        unknown = [a for a in actions if a not in self.agents]
        if unknown:
            raise ValueError(
                f"actions given for unknown or finished agent(s) {unknown}; live agents are "
                f"{self.agents}"
            )
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"no action given for agent(s) {missing}")
        control_dim = int(self.vehicle.control_dim)
        controls = np.empty((self.n_agents, control_dim))
        for agent in self.possible_agents:
            i = self.agent_name_mapping[agent]
            action = actions[agent]
            if self.discrete_controls is not None:
                controls[i] = self.discrete_controls[self._discrete_index(agent, action)]
                continue
            try:
                value = np.asarray(action, dtype=np.float64)
            except (TypeError, ValueError) as error:
                raise TypeError(
                    f"action of {agent} must be a numeric array of shape ({control_dim},), "
                    f"got {action!r}"
                ) from error
            if value.shape != (control_dim,):
                raise ValueError(
                    f"action of {agent} must have shape ({control_dim},), got shape {value.shape}"
                )
            if not np.all(np.isfinite(value)):
                raise ValueError(f"action of {agent} must be finite, got {value.tolist()}")
            controls[i] = np.clip(value, self.control_low, self.control_high)
        return controls

    def _discrete_index(self, agent: str, action: Any) -> int:
        assert self.discrete_controls is not None  # discrete action type
        n_actions = len(self.discrete_controls)
        if isinstance(action, np.ndarray) and action.shape in ((), (1,)):
            action = action.reshape(()).item() if action.dtype.kind in "iu" else action
        if isinstance(action, bool | np.bool_) or not isinstance(action, int | np.integer):
            raise TypeError(
                f"discrete action of {agent} must be an integer in [0, {n_actions}), got {action!r}"
            )
        if not 0 <= int(action) < n_actions:
            raise ValueError(
                f"discrete action of {agent} must be in [0, {n_actions}), got {int(action)}"
            )
        return int(action)

    def _reception(self, positions: FloatArray) -> NDArray[np.bool_]:
        """``(A, A)`` matrix: ``[i, j]`` is True when agent i receives agent j's observation."""
        n = self.n_agents
        uniforms = self._message_rng.random((n, n))  # drawn every step: streams stay aligned
        reception = uniforms >= self.message_loss
        if self.message_loss >= 1.0:
            reception[:] = False
        if math.isfinite(self.comm_range):
            reception &= pairwise_distances(positions) <= self.comm_range
        np.fill_diagonal(reception, True)
        return reception

    def _observe_all(self) -> tuple[dict[str, ObsArray], dict[str, dict[str, Any]]]:
        n = self.n_agents
        states = self._current_states()
        positions = self.vehicle.position(states)
        relative = positions[None, :, :] - positions[:, None, :]  # [i, j] = x_j - x_i
        others = relative[~np.eye(n, dtype=bool)].reshape(n, 2 * (n - 1))
        grids = np.stack([b.mass_grid(self.belief_grid).ravel() for b in self._beliefs])
        estimates = np.stack([b.mmse() for b in self._beliefs])
        masses = np.array(
            [
                b.mass_within(self.localization_radius, e)
                for b, e in zip(self._beliefs, estimates, strict=True)
            ]
        )
        flat = np.concatenate([states, others, grids, estimates], axis=1).astype(np.float32)
        flat = np.clip(flat, self._obs_low, self._obs_high)  # float32 rounding at the bounds
        state = np.concatenate([states.ravel(), grids.ravel(), estimates.ravel(), masses])
        self._state = np.clip(state.astype(np.float32), self._state_low, self._state_high)
        vehicle_states = _readonly(states.copy())
        observations: dict[str, ObsArray] = {}
        infos: dict[str, dict[str, Any]] = {}
        for i, agent in enumerate(self.possible_agents):
            belief = self._beliefs[i]
            observations[agent] = flat[i].copy()
            infos[agent] = {
                "vehicle_states": vehicle_states,
                "agent_index": i,
                "belief_recovered": bool(self._recovered[i]),
                "ess": float(belief.ess),
                "entropy": float(self._entropies[i]),
                "posterior_mass": float(masses[i]),
                "separation_violations": int(self._violations[i]),
            }
            if self.belief_in_infos:
                infos[agent]["belief"] = belief.view()
        return observations, infos

    def state(self) -> ObsArray:
        """The centralised state (float32, ``state_space``; layout ``state_layout``): every
        vehicle's state, every agent's belief grid, MMSE estimate and posterior mass; never the
        true target (:mod:`infoseek.envs.spaces`).

        Raises:
            RuntimeError: Called before ``reset()``.
        """
        if self._state is None:
            raise RuntimeError("state() called before reset(): call reset() first")
        return self._state.copy()

    # ----------------------------------------------------------------------------- accessors
    def _current_states(self) -> FloatArray:
        if self._states is None:
            raise RuntimeError("the episode has not started: call reset() first")
        return self._states

    def _current_target(self) -> FloatArray:
        if self._target is None:
            raise RuntimeError("the episode has not started: call reset() first")
        return self._target

    def true_target(self) -> FloatArray:
        """A copy of the true target state ``(d,)`` (for benchmarks only; never in observations)."""
        if self._target is None:
            raise RuntimeError("true_target() called before reset()")
        return self._target.copy()

    def belief(self, agent: str) -> BeliefView:
        """Read-only snapshot of ``agent``'s belief (what the scripted planners read).

        Raises:
            ValueError: ``agent`` is not one of ``possible_agents``.
            RuntimeError: Called before ``reset()``.
        """
        index = self.agent_name_mapping[self._agent_index(agent, "belief")]
        if not self._beliefs:
            raise RuntimeError(f"belief({agent!r}) called before reset(): call reset() first")
        return self._beliefs[index].view()

    def agent_belief(self, agent: str) -> ParticleBelief:
        """The live :class:`ParticleBelief` of ``agent`` (diagnostics; do not mutate)."""
        return self._beliefs[self.agent_name_mapping[self._agent_index(agent, "agent_belief")]]

    @property
    def vehicle_states(self) -> FloatArray:
        """Read-only ``(A, state_dim)`` copy of every vehicle's state."""
        return _readonly(self._current_states().copy())

    @property
    def cycles(self) -> int:
        """Steps taken in the current episode."""
        return self._cycles

    # ----------------------------------------------------------------------------- rendering
    @property
    def renderer(self) -> Any:
        """The :class:`~infoseek.envs.rendering.SearchRenderer` drawing this episode's frames
        (``None`` before the first ``render()`` and after ``close()``)."""
        return self._renderer

    def render(self) -> NDArray[np.uint8] | None:
        """Draw agent 0's belief, the trails, the MMSE estimate (X) and the true target (square).

        Returns:
            ``(H, W, 3)`` uint8 frame for ``render_mode="rgb_array"``; ``None`` otherwise.
        """
        if self.render_mode is None:
            gymnasium.logger.warn(
                "render() called with render_mode=None; pass render_mode='rgb_array' or 'human'"
            )
            return None
        if self._target is None:
            raise RuntimeError("render() called before reset()")
        from infoseek.envs.rendering import SearchRenderer

        if self._renderer is None:
            self._renderer = SearchRenderer(
                self.space, human=self.render_mode == "human", title=self.metadata["name"]
            )
        belief = self._beliefs[0]
        estimate = belief.mmse()
        frame = self._renderer.draw(
            particles=np.asarray(belief.particles),
            weights=np.asarray(belief.weights),
            estimate=estimate,
            target=self._target,
            trails=np.stack(self._trails) if self._trails else None,
            step=self._cycles,
            headings=self._headings(self._current_states()),
            mass=float(belief.mass_within(self.localization_radius, estimate)),
            radius=self.localization_radius,
        )
        return frame if self.render_mode == "rgb_array" else None

    def _headings(self, states: FloatArray) -> FloatArray:
        """``(A, 2)`` unit vectors along each vehicle's heading (a ``heading`` state) or
        velocity (``vx``, ``vy`` states; zero at rest), for the rendered arrows."""
        names = list(self.vehicle.state_names)
        if "heading" in names:
            angle = states[:, names.index("heading")]
            return np.stack([np.cos(angle), np.sin(angle)], axis=1)
        if "vx" in names and "vy" in names:
            velocity = states[:, [names.index("vx"), names.index("vy")]]
            speed = np.linalg.norm(velocity, axis=1, keepdims=True)
            return np.where(speed > 1e-9, velocity / np.maximum(speed, 1e-9), 0.0)
        return np.zeros((states.shape[0], 2))

    def close(self) -> None:
        """Release the rendering figure."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
