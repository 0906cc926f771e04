"""Configuration of the information-seeking environment: validated settings, components,
start geometry, action decoding and the observation/state spaces.

:class:`SearchConfig` is everything an episode needs that does not change during it. It is
built once per environment (:class:`~infoseek.envs.search_env.InformationSeekingEnv`, or a
batched :class:`~infoseek.envs.core.SearchCore` shared by a vector of environments); every
setting is checked here, with an error naming it, before anything runs.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

import gymnasium
import numpy as np
from numpy.typing import NDArray

from infoseek.envs.belief import default_tempering_ess
from infoseek.envs.sensors import make_sensor
from infoseek.envs.sensors.base import Sensor
from infoseek.envs.spaces import observation_layout, position_box, state_layout
from infoseek.envs.targets import TargetMotion, TargetSpace, make_target_motion
from infoseek.envs.vehicles import make_vehicle
from infoseek.envs.vehicles.base import Vehicle

FloatArray = NDArray[np.float64]
_Choice = TypeVar("_Choice")

ACTION_TYPES = ("continuous", "discrete")
#: Fewest particles per belief: fewer cannot represent the uniform prior (a 40 x 40 domain
#: sampled by 100 particles already leaves ~4 units between neighbours), and the posterior-mass
#: and localisation metrics of a belief of a handful of particles are meaningless.
MIN_PARTICLES = 100
RENDER_MODES = (None, "rgb_array", "human")


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


def _check_size_pair(value: object, name: str) -> tuple[float, float]:
    """A ``(width, height)`` pair of positive finite numbers, errors naming ``name``."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
        raise TypeError(f"{name} must be a (width, height) pair of positive numbers, got {value!r}")
    if len(value) != 2:
        raise ValueError(f"{name} must be a (width, height) pair, got {len(value)} value(s)")
    return (
        _check_float(value[0], f"{name}[0]", low=0.0, low_open=True),
        _check_float(value[1], f"{name}[1]", low=0.0, low_open=True),
    )


def _check_bins(value: object, name: str) -> tuple[int, ...] | None:
    """``None`` or a sequence of integers >= 1 (one per target dimension; the belief checks
    the count), errors naming ``name``."""
    if value is None:
        return None
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
        raise TypeError(
            f"{name} must be a tuple of integers >= 1 (one per target dimension) or None, "
            f"got {value!r}"
        )
    return tuple(_check_int(bins, f"{name}[{k}]", 1) for k, bins in enumerate(value))


def _as_floats(value: object, name: str) -> FloatArray:
    """``value`` as a float64 array; a ``TypeError`` naming ``name`` if it is not numbers."""
    try:
        return np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers, got {value!r}") from None


def _named(name: str, factory: Any, spec: object, kwargs: dict[str, Any]) -> Any:
    """``factory(spec, **kwargs)`` (a registry lookup), its errors prefixed with ``name``
    unless they already name it."""
    try:
        return factory(spec, **kwargs)
    except (TypeError, ValueError) as error:
        if name in str(error):
            raise
        raise type(error)(f"{name}: {error}") from None


def _check_kwargs(value: object, name: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise TypeError(f"{name} must be a dict of keyword arguments or None, got {value!r}")
    return dict(value)


def _check_flag(value: object, name: str, expected: str = "True or False") -> bool:
    """``value`` (a Python or numpy bool) as a bool; a ``TypeError`` naming ``name`` and saying
    what is ``expected`` otherwise."""
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be {expected}, got {value!r}")
    return bool(value)


def _check_choice(value: _Choice, name: str, choices: tuple[object, ...]) -> _Choice:
    """``value`` if it is one of ``choices``; a ``ValueError`` naming ``name`` otherwise."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
    return value


def _check_belief_grid(value: object) -> tuple[int, int]:
    """The ``(gx, gy)`` belief-mass grid: two integers >= 1."""
    if (
        not isinstance(value, Sequence)
        or len(value) != 2
        or any(isinstance(g, bool) or not isinstance(g, int | np.integer) for g in value)
        or min(value) < 1
    ):
        raise ValueError(f"belief_grid must be two integers >= 1, got {value!r}")
    return (int(value[0]), int(value[1]))


def _check_tempering_ess(value: float | None, motion: TargetMotion) -> float:
    """The progressive-correction floor in ``[0, 1)``; ``None`` is the default for ``motion``."""
    if value is None:
        value = default_tempering_ess(motion)
    tempering_ess = _check_float(value, "tempering_ess", low=0.0, high=1.0)
    if tempering_ess >= 1.0:
        raise ValueError(f"tempering_ess must be in [0, 1), got {value!r}")
    return tempering_ess


def _filter_model(sensor: Sensor, filter_max_snr: float | None) -> tuple[float | None, Sensor]:
    """The checked noise floor and the likelihood model every belief update uses: ``sensor``
    itself when the floor is ``None``, else its noise-floored view ``with_max_snr``."""
    if filter_max_snr is None:
        return None, sensor
    max_snr = _check_float(filter_max_snr, "filter_max_snr", low=0.0, low_open=True)
    if not callable(getattr(sensor, "with_max_snr", None)):
        raise ValueError(
            f"filter_max_snr needs a sensor that offers with_max_snr (e.g. 'beacon'); "
            f"sensor {sensor.name!r} does not: use filter_max_snr=None"
        )
    return max_snr, sensor.with_max_snr(max_snr)  # type: ignore[attr-defined]


def _control_grid(low: FloatArray, high: FloatArray, n_per_axis: int) -> FloatArray:
    """``(k**c, c)`` controls: ``k = n_per_axis`` evenly spaced values from ``low`` to ``high``
    on each of the ``c`` axes, every combination, the last axis varying fastest."""
    axes = [np.linspace(lo, hi, n_per_axis) for lo, hi in zip(low, high, strict=True)]
    grid = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grid], axis=-1)


def read_only(array: np.ndarray) -> np.ndarray:
    """``array``, marked read-only in place (for arrays handed out that no one may change)."""
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


class SearchConfig:
    """Validated settings of a search environment (the keywords of every env constructor).

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
            :mod:`infoseek.envs.belief`); ``None``: 0.1 for a stationary target, 0 for a
            moving one (:func:`~infoseek.envs.belief.default_tempering_ess`).
        filter_max_snr: Filter noise floor (module docstring): ``None`` evaluates the exact
            likelihood; a float ``c > 0`` makes every belief update (and the planners) use
            ``sensor.with_max_snr(c)`` (the sensor must offer it). The model the beliefs use is
            the attribute ``filter_sensor`` (the sensor itself when ``None``).
        entropy_bins: Histogram grid of the belief entropy estimate (``None``: belief default).
        belief_grid: ``(gx, gy)`` coarse belief-mass grid in the observation.
        belief_moments: Append the block ``belief_moments`` to every observation: the standard
            deviations and correlation of the own belief's planar position and its posterior
            mass near the MMSE estimate (:mod:`infoseek.envs.spaces`). Off by default.
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
        tempering_ess: float | None = None,
        filter_max_snr: float | None = None,
        entropy_bins: tuple[int, ...] | None = None,
        belief_grid: tuple[int, int] = (8, 8),
        belief_moments: bool = False,
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
        # the settings are checked in this order: of several bad ones, the first is reported
        self._set_components(
            sensor, sensor_kwargs, vehicle, vehicle_kwargs, target_motion, target_motion_kwargs
        )
        self._set_space(target_space, domain_size)
        self._set_sizes(n_agents, n_particles, max_cycles, dt, min_separation, separation_penalty)
        self._set_filter(resample_threshold, roughening, tempering_ess, filter_max_snr)
        self._set_localization(localization_radius, localization_mass, terminate_on_localization)
        self._set_communication(comm_range, message_loss)
        self._set_belief_summaries(entropy_bins, belief_grid, belief_moments)
        self._set_reporting(render_mode, belief_in_infos, name)
        self._set_agents(start_center, start_spacing, start_positions)
        self._set_actions(action_type, n_discrete_actions)
        self._build_spaces()

    # ----------------------------------------------------------------------------- settings
    def _set_components(
        self,
        sensor: str | Sensor,
        sensor_kwargs: Mapping[str, Any] | None,
        vehicle: str | Vehicle,
        vehicle_kwargs: Mapping[str, Any] | None,
        target_motion: str | TargetMotion,
        target_motion_kwargs: Mapping[str, Any] | None,
    ) -> None:
        """The sensor, vehicle and target motion, built from their registries (or as given)."""
        self.sensor: Sensor = _named(
            "sensor", make_sensor, sensor, _check_kwargs(sensor_kwargs, "sensor_kwargs")
        )
        self.vehicle: Vehicle = _named(
            "vehicle", make_vehicle, vehicle, _check_kwargs(vehicle_kwargs, "vehicle_kwargs")
        )
        self.target_motion: TargetMotion = _named(
            "target_motion",
            make_target_motion,
            target_motion,
            _check_kwargs(target_motion_kwargs, "target_motion_kwargs"),
        )

    def _set_space(
        self, target_space: TargetSpace | str | None, domain_size: tuple[float, float] | None
    ) -> None:
        """The target space, whose dimension must be the one the sensor observes."""
        self.space: TargetSpace = self._build_space(target_space, domain_size)
        if self.sensor.target_dim != self.space.dim:
            raise ValueError(
                f"target_space has dim {self.space.dim} but sensor {self.sensor.name!r} expects "
                f"targets of dim {self.sensor.target_dim}"
            )

    def _set_sizes(
        self,
        n_agents: int,
        n_particles: int,
        max_cycles: int,
        dt: float,
        min_separation: float,
        separation_penalty: float,
    ) -> None:
        """Vehicles, particles, episode length and time step; the separation rule (eq. 2)."""
        self.n_agents = _check_int(n_agents, "n_agents", 1)
        self.n_particles = _check_int(n_particles, "n_particles", MIN_PARTICLES)
        self._max_cycles = _check_int(max_cycles, "max_cycles", 1)
        self.dt = _check_float(dt, "dt", low=0.0, low_open=True)
        self.min_separation = _check_float(min_separation, "min_separation", low=0.0)
        self.separation_penalty = _check_float(separation_penalty, "separation_penalty", low=0.0)

    def _set_filter(
        self,
        resample_threshold: float,
        roughening: float,
        tempering_ess: float | None,
        filter_max_snr: float | None,
    ) -> None:
        """The particle filter's settings and the likelihood model its updates use."""
        self.resample_threshold = _check_float(
            resample_threshold, "resample_threshold", low=0.0, high=1.0
        )
        self.roughening = _check_float(roughening, "roughening", low=0.0)
        self.tempering_ess = _check_tempering_ess(tempering_ess, self.target_motion)
        self.filter_max_snr, self.filter_sensor = _filter_model(self.sensor, filter_max_snr)

    def _set_localization(
        self,
        localization_radius: float,
        localization_mass: float,
        terminate_on_localization: bool,
    ) -> None:
        """The posterior-mass criterion of a localised belief, and whether it ends episodes."""
        self.localization_radius = _check_float(
            localization_radius, "localization_radius", low=0.0, low_open=True
        )
        self.localization_mass = _check_float(
            localization_mass, "localization_mass", low=0.0, high=1.0, low_open=True
        )
        self.terminate_on_localization = _check_flag(
            terminate_on_localization, "terminate_on_localization", "a bool"
        )

    def _set_communication(self, comm_range: float, message_loss: float) -> None:
        """How far observations are shared, and how often a message is lost."""
        self.comm_range = _check_float(comm_range, "comm_range", low=0.0, allow_inf=True)
        self.message_loss = _check_float(message_loss, "message_loss", low=0.0, high=1.0)

    def _set_belief_summaries(
        self,
        entropy_bins: tuple[int, ...] | None,
        belief_grid: tuple[int, int],
        belief_moments: bool,
    ) -> None:
        """How beliefs are summarised: entropy histogram, observed mass grid and moments."""
        self.entropy_bins = _check_bins(entropy_bins, "entropy_bins")
        self.belief_grid = _check_belief_grid(belief_grid)
        self.belief_moments = _check_flag(belief_moments, "belief_moments")

    def _set_reporting(self, render_mode: str | None, belief_in_infos: bool, name: str) -> None:
        """Rendering, what the infos carry and the environment's name."""
        self.render_mode = _check_choice(render_mode, "render_mode", RENDER_MODES)
        self.belief_in_infos = _check_flag(belief_in_infos, "belief_in_infos")
        if not isinstance(name, str) or not name:
            raise TypeError(f"name must be a non-empty string, got {name!r}")
        self.name = name

    def _set_agents(
        self,
        start_center: Sequence[float],
        start_spacing: float | None,
        start_positions: Sequence[Sequence[float]] | FloatArray | None,
    ) -> None:
        """The agents' names and indices, and their (read-only) start positions."""
        self.possible_agents = [f"vehicle_{i}" for i in range(self.n_agents)]
        self.agent_name_mapping = {agent: i for i, agent in enumerate(self.possible_agents)}
        self.start_positions = read_only(
            self._build_start_positions(start_center, start_spacing, start_positions)
        )

    def _set_actions(self, action_type: str, n_discrete_actions: int) -> None:
        """The action space: the vehicle's control box, or the grid of its discrete controls."""
        self.action_type = _check_choice(action_type, "action_type", ACTION_TYPES)
        self.control_low = np.asarray(self.vehicle.control_low, dtype=np.float64)
        self.control_high = np.asarray(self.vehicle.control_high, dtype=np.float64)
        control_dim = int(self.vehicle.control_dim)
        self.n_discrete_actions = _check_int(n_discrete_actions, "n_discrete_actions", 2)
        if action_type == "discrete":
            self.discrete_controls: FloatArray | None = read_only(
                _control_grid(self.control_low, self.control_high, self.n_discrete_actions)
            )
            self.action_space: gymnasium.spaces.Space = gymnasium.spaces.Discrete(
                len(self.discrete_controls)
            )
        else:
            self.discrete_controls = None
            self.action_space = gymnasium.spaces.Box(
                low=self.control_low.astype(np.float32),
                high=self.control_high.astype(np.float32),
                shape=(control_dim,),
                dtype=np.float32,
            )

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
        size = (40.0, 40.0) if domain_size is None else _check_size_pair(domain_size, "domain_size")
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
            positions = _as_floats(start_positions, "start_positions")
            if positions.shape != (self.n_agents, 2) or not np.all(np.isfinite(positions)):
                raise ValueError(
                    f"start_positions must be a finite ({self.n_agents}, 2) array (one row per "
                    f"agent), got shape {positions.shape}"
                )
        else:
            center = _as_floats(start_center, "start_center")
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
        self.observation_layout, obs_low, obs_high = observation_layout(
            *geometry, belief_moments=self.belief_moments
        )
        self.obs_low = obs_low.astype(np.float32)
        self.obs_high = obs_high.astype(np.float32)
        self.observation_space = gymnasium.spaces.Box(
            low=self.obs_low, high=self.obs_high, dtype=np.float32
        )
        self.state_layout, state_low, state_high = state_layout(*geometry)
        self.state_low = state_low.astype(np.float32)
        self.state_high = state_high.astype(np.float32)
        self.state_space = gymnasium.spaces.Box(
            low=self.state_low, high=self.state_high, dtype=np.float32
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

    def decode_actions(self, actions: object, n_envs: int, name: str = "actions") -> FloatArray:
        """``(B, A, control_dim)`` controls from a batch of actions.

        Args:
            actions: ``(B, A)`` (or ``(B * A,)``) integer indices into :attr:`discrete_controls`
                for discrete actions; ``(B, A, control_dim)`` (or ``(B * A, control_dim)``)
                finite controls, clipped to the vehicle's bounds, for continuous ones.
            n_envs: Number of environments ``B``.
            name: Name of the argument in error messages.

        Raises:
            ValueError: Wrong shape, non-finite controls or an index out of range.
            TypeError: Non-integer discrete actions.
        """
        a = self.n_agents
        array = np.asarray(actions)
        if self.discrete_controls is not None:
            n_actions = len(self.discrete_controls)
            if array.shape not in ((n_envs, a), (n_envs * a,)):
                raise ValueError(
                    f"{name} must have shape ({n_envs}, {a}) or ({n_envs * a},) (discrete action "
                    f"indices per environment and agent), got shape {array.shape}"
                )
            if array.dtype.kind not in "iu":
                if array.dtype.kind != "f" or not np.all(
                    np.isfinite(array) & (array == np.round(array))
                ):
                    raise TypeError(
                        f"{name} must be integers in [0, {n_actions}), got {array.dtype}"
                    )
            index = array.astype(np.int64).reshape(n_envs, a)
            if index.min() < 0 or index.max() >= n_actions:
                raise ValueError(
                    f"{name} must be in [0, {n_actions}), got {index.min()}..{index.max()}"
                )
            return self.discrete_controls[index]
        c = int(self.vehicle.control_dim)
        if array.shape not in ((n_envs, a, c), (n_envs * a, c)):
            raise ValueError(
                f"{name} must have shape ({n_envs}, {a}, {c}) or ({n_envs * a}, {c}) (one control "
                f"vector per environment and agent), got shape {array.shape}"
            )
        try:
            value = array.astype(np.float64).reshape(n_envs, a, c)
        except (TypeError, ValueError) as error:
            raise TypeError(f"{name} must be numeric, got {array.dtype}") from error
        if not np.all(np.isfinite(value)):
            raise ValueError(f"{name} must be finite (got NaN or inf)")
        return np.clip(value, self.control_low, self.control_high)
