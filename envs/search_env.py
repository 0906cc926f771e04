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

import copy
import warnings
from collections.abc import Mapping
from typing import Any

import gymnasium
import numpy as np
from numpy.typing import NDArray
from pettingzoo import ParallelEnv

from infoseek.envs.belief import BeliefView, ParticleBelief, belief_view
from infoseek.envs.config import (
    MIN_PARTICLES,
    SearchConfig,
    clustered_start_positions,
    pairwise_distances,
    read_only,
)
from infoseek.envs.core import SearchCore, separation_violations

FloatArray = NDArray[np.float64]
ObsArray = NDArray[np.float32]

__all__ = [
    "INFO_KEYS",
    "MIN_PARTICLES",
    "InformationSeekingEnv",
    "clustered_start_positions",
    "pairwise_distances",
    "separation_violations",
]

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


class InformationSeekingEnv(ParallelEnv):
    """Parallel PettingZoo environment: a team of vehicles searching for one target.

    A view of a :class:`~infoseek.envs.core.SearchCore` with one environment: the simulation,
    filtering and reward are the core's; this class turns its arrays into PettingZoo's
    per-agent dicts, checks the actions and draws the frames.

    Args:
        **config: Every keyword of :class:`~infoseek.envs.config.SearchConfig` (its docstring
            lists them; an unknown one raises ``ValueError`` listing the valid ones).

    Attributes:
        config: The validated settings (``env.config.sensor``, ``env.config.n_agents``,
            ``env.config.filter_sensor``, ...; through PettingZoo wrappers
            ``env.unwrapped.config``). They are read there, in one place: the environment does
            not forward them as attributes of its own.
    """

    metadata: dict[str, Any] = {
        "name": "information_seeking",
        "render_modes": ["human", "rgb_array"],
        "render_fps": 4,
        "is_parallelizable": True,
    }

    def __init__(self, **config: Any) -> None:
        self.config = SearchConfig(**config)
        self.metadata = {**type(self).metadata, "name": self.config.name}
        self.render_mode = self.config.render_mode
        self.possible_agents = list(self.config.possible_agents)
        self.agent_name_mapping = dict(self.config.agent_name_mapping)
        self.agents: list[str] = []
        self._core = SearchCore(self.config, 1)
        self._action_spaces = {
            a: copy.deepcopy(self.config.action_space) for a in self.possible_agents
        }
        self._build_observation_spaces()
        self._trails: list[FloatArray] = []
        self._renderer: Any = None

    @classmethod
    def config_keys(cls) -> tuple[str, ...]:
        """Names of every accepted configuration keyword."""
        return SearchConfig.config_keys()

    def _build_observation_spaces(self) -> None:
        self._observation_spaces = {
            a: copy.deepcopy(self.config.observation_space) for a in self.possible_agents
        }
        self.state_space = copy.deepcopy(self.config.state_space)

    @property
    def max_cycles(self) -> int:
        """Steps before truncation. Reassigning it (between episodes) rebuilds the observation
        and state spaces, whose position bounds grow with the episode length."""
        return self.config.max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        self.config.max_cycles = value
        self._build_observation_spaces()

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
        target = self._target_from_options(options) if options else None
        self._core.reset([0], [seed], [target])
        self.agents = list(self.possible_agents)
        positions = self.config.vehicle.position(self._core.states[0])
        self._trails = [positions.copy()] if self.render_mode is not None else []
        observations, infos = self._observe_all()
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def _target_from_options(self, options: Mapping[str, Any]) -> FloatArray | None:
        unknown = sorted(set(options) - {"target"})
        if unknown:
            # PettingZoo's API tests pass arbitrary options; ignore them, but not silently.
            warnings.warn(
                f"reset options: ignoring unknown keys {unknown}; valid keys are ['target']",
                stacklevel=3,
            )
        if "target" not in options:
            return None
        target = np.asarray(options["target"], dtype=np.float64)
        if target.shape != (self.config.space.dim,) or not np.all(np.isfinite(target)):
            raise ValueError(
                f"reset options['target'] must be {self.config.space.dim} finite numbers "
                f"{self.config.space.names}, got {options['target']!r}"
            )
        target = self.config.space.wrap(target[None])[0]
        if not bool(np.all(self.config.space.contains(target[None]))):
            raise ValueError(
                f"reset options['target'] {target.tolist()} lies outside the domain "
                f"[{self.config.space.low}, {self.config.space.high}]"
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
        result = self._core.step(controls[None])
        if self.render_mode is not None:
            self._trails.append(self.config.vehicle.position(self._core.states[0]).copy())
        observations, infos = self._observe_all(result.observations[0])
        rewards = {
            agent: float(result.rewards[0, i]) for i, agent in enumerate(self.possible_agents)
        }
        localised, truncated = bool(result.terminated[0]), bool(result.truncated[0])
        terminations = dict.fromkeys(self.possible_agents, localised)
        truncations = dict.fromkeys(self.possible_agents, truncated)
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
        control_dim = int(self.config.vehicle.control_dim)
        controls = np.empty((self.config.n_agents, control_dim))
        for agent in self.possible_agents:
            i = self.agent_name_mapping[agent]
            action = actions[agent]
            if self.config.discrete_controls is not None:
                controls[i] = self.config.discrete_controls[self._discrete_index(agent, action)]
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
            controls[i] = np.clip(value, self.config.control_low, self.config.control_high)
        return controls

    def _discrete_index(self, agent: str, action: Any) -> int:
        assert self.config.discrete_controls is not None  # discrete action type
        n_actions = len(self.config.discrete_controls)
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

    def _observe_all(
        self, flat: ObsArray | None = None
    ) -> tuple[dict[str, ObsArray], dict[str, dict[str, Any]]]:
        core = self._core
        flat = core.observations()[0] if flat is None else flat
        vehicle_states = read_only(core.states[0].copy())
        observations: dict[str, ObsArray] = {}
        infos: dict[str, dict[str, Any]] = {}
        for i, agent in enumerate(self.possible_agents):
            observations[agent] = flat[i].copy()
            infos[agent] = {
                "vehicle_states": vehicle_states,
                "agent_index": i,
                "belief_recovered": bool(core.recovered[0, i]),
                "ess": float(core.ess[0, i]),
                "entropy": float(core.entropies[0, i]),
                "posterior_mass": float(core.masses[0, i]),
                "separation_violations": int(core.violations[0, i]),
            }
            if self.config.belief_in_infos:
                infos[agent]["belief"] = self._view(i)
        return observations, infos

    def state(self) -> ObsArray:
        """The centralised state (float32, ``state_space``; layout ``state_layout``): every
        vehicle's state, every agent's belief grid, MMSE estimate and posterior mass; never the
        true target (:mod:`infoseek.envs.spaces`).

        Raises:
            RuntimeError: Called before ``reset()``.
        """
        self._require_started("state()")
        return self._core.state(0)

    # ----------------------------------------------------------------------------- accessors
    def _require_started(self, what: str) -> None:
        if not self._core.started[0]:
            raise RuntimeError(f"{what} called before reset(): call reset() first")

    def _view(self, index: int) -> BeliefView:
        return belief_view(self._core.beliefs, index)

    def true_target(self) -> FloatArray:
        """A copy of the true target state ``(d,)`` (for benchmarks only; never in observations)."""
        self._require_started("true_target()")
        return self._core.targets[0].copy()

    def belief(self, agent: str) -> BeliefView:
        """Read-only snapshot of ``agent``'s belief (what the scripted planners read).

        Raises:
            ValueError: ``agent`` is not one of ``possible_agents``.
            RuntimeError: Called before ``reset()``.
        """
        index = self.agent_name_mapping[self._agent_index(agent, "belief")]
        self._require_started(f"belief({agent!r})")
        return self._view(index)

    def agent_belief(self, agent: str) -> ParticleBelief:
        """A :class:`ParticleBelief` copy of ``agent``'s current belief (diagnostics), its
        generator a copy of the belief's stream (drawing from it leaves the episode alone)."""
        index = self.agent_name_mapping[self._agent_index(agent, "agent_belief")]
        self._require_started(f"agent_belief({agent!r})")
        return ParticleBelief.row_of(self._core.beliefs, index)

    @property
    def vehicle_states(self) -> FloatArray:
        """Read-only ``(A, state_dim)`` copy of every vehicle's state."""
        self._require_started("vehicle_states")
        return read_only(self._core.states[0].copy())

    @property
    def cycles(self) -> int:
        """Steps taken in the current episode."""
        return int(self._core.cycles[0])

    @property
    def last_measurements(self) -> FloatArray | None:
        """Read-only ``(A, obs_dim)`` measurements of the last step (``None`` before one)."""
        measured = self._core.last_measurements
        return None if measured is None or self.cycles == 0 else read_only(measured[0].copy())

    @property
    def last_reception(self) -> NDArray[np.bool_] | None:
        """Read-only ``(A, A)`` reception matrix of the last step (``None`` before one)."""
        reception = self._core.last_reception
        return None if reception is None or self.cycles == 0 else read_only(reception[0].copy())

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
        if not self._core.started[0]:
            raise RuntimeError("render() called before reset()")
        from infoseek.envs.rendering import SearchRenderer

        if self._renderer is None:
            self._renderer = SearchRenderer(
                self.config.space, human=self.render_mode == "human", title=self.metadata["name"]
            )
        belief = self.agent_belief(self.possible_agents[0])
        estimate = belief.mmse()
        frame = self._renderer.draw(
            particles=np.asarray(belief.particles),
            weights=np.asarray(belief.weights),
            estimate=estimate,
            target=self.true_target(),
            trails=np.stack(self._trails) if self._trails else None,
            step=self.cycles,
            headings=self._headings(self._core.states[0]),
            mass=float(belief.mass_within(self.config.localization_radius, estimate)),
            radius=self.config.localization_radius,
        )
        return frame if self.render_mode == "rgb_array" else None

    def _headings(self, states: FloatArray) -> FloatArray:
        """``(A, 2)`` unit vectors along each vehicle's heading (a ``heading`` state) or
        velocity (``vx``, ``vy`` states; zero at rest), for the rendered arrows."""
        names = list(self.config.vehicle.state_names)
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
