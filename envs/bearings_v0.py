r"""
# Bearings v0

Airplanes with bearings-only sensors (cameras) search a 40 x 40 domain for a stationary target
(section IV-A of Hoffmann, Waslander & Tomlin 2006).

| Creation             | `infoseek.envs.make("bearings_v0")`, `bearings_v0.parallel_env()` |
|----------------------|----------------------------------------------------------------|
| Actions              | Continuous (default) or discrete                               |
| Parallel API         | Yes (native); AEC via `env()`                                  |
| Agents               | `["vehicle_0", ..., "vehicle_{n_agents-1}"]`                   |
| Agents (default)     | 4                                                              |
| Action shape         | `(1,)` turn rate in `[-0.5, 0.5]` rad/s, or `Discrete(5)`      |
| Observation shape    | `(2 * n_agents + 67,)` float32 (75 for 4 agents)               |
| Target state         | `(x, y)`, uniform prior on `[0, 40) x [0, 40)`                  |

**Model.** Vehicle ``i`` is an airplane (state ``(x, y, heading)``, heading in ``[-pi, pi)``)
flying at constant speed (1 unit/s) and turning at a commanded rate
``u in [-max_turn_rate, max_turn_rate]``, integrated exactly along the circular arc over ``dt``
(eq. 1). Every ``dt`` each vehicle measures the bearing to the target,
``z = atan2(y_s - y, x_s - x) + eta`` wrapped into ``[-pi, pi)``, ``eta ~ N(0, sigma^2)``
(wrapped-normal likelihood). All airplanes start clustered around ``(5, 5)``, heading
``pi/4``. Every agent keeps its own 2000-particle filter with the uniform prior and, by default,
incorporates every agent's observation every step (the paper's full communication).

**Observations** (flat float32 Box, identical for every agent so one shared policy can be
trained; the slices are in ``env.unwrapped.config.observation_layout``):

| Slice name                  | Size             | Content                        | Bounds |
|-----------------------------|------------------|--------------------------------|--------|
| `own_state`                 | 3                | own `(x, y, heading)`          | (1)    |
| `others_relative_positions` | `2 (n_agents-1)` | `x_j - x_i` for j != i, by index | (R) |
| `belief_grid`               | 64               | own belief's mass on 8 x 8 cells (2) | `[0, 1]` |
| `mmse_estimate`             | 2                | own MMSE estimate `(x, y)` (eq. 12) | `[0, 40]` |
| `belief_moments`            | 4 (optional)     | own belief's `(s_x, s_y, rho, mass)` (3) | (3) |

(1) x, y within the reachable box: the domain and the start positions grown on every side by
`speed * dt * max_cycles` (airplanes may leave the domain, but not that box); heading in
`[-pi, pi]`. (R) within plus or minus the reachable box's width and height. Every bound is
finite (:mod:`infoseek.envs.spaces`); reassigning `max_cycles` rebuilds the spaces.
(2) position mass of each cell of a regular 8 x 8 grid over the domain, cell `[ix, iy]` at
flat index `ix * 8 + iy` (x index slowest).
(3) only with `belief_moments=True`: the standard deviations of the own belief's planar
position (within the domain's width and height), their correlation (`[-1, 1]`) and the
posterior mass within `localization_radius` of the MMSE estimate (`[0, 1]`); see
:mod:`infoseek.envs.spaces`.

**Actions.** ``action_type="continuous"``: a ``(1,)`` turn rate; values outside
``[-max_turn_rate, max_turn_rate]`` are clipped (not rejected), NaN/inf raise ``ValueError``.
``action_type="discrete"``: an integer ``k`` in ``[0, n_discrete_actions)`` meaning turn rate
``env.unwrapped.config.discrete_controls[k]`` (evenly spaced from ``-max_turn_rate`` to
``+max_turn_rate``).

**Reward.** Per agent and step: the entropy reduction of its own belief,
``H_{t-1} - H_t`` (histogram estimate of eq. 6 on a grid adapted to the particles, in nats; it
reads ``log(1600) = 7.38`` at the uniform prior for any particle count; reported as
``infos[agent]["entropy"]``),
minus ``separation_penalty`` (default 1.0) per other vehicle closer than ``min_separation``
(eq. 2; default 1.0 unit).

**Termination / truncation.** Truncation after ``max_cycles`` steps (default 60). With
``terminate_on_localization=True`` every agent terminates as soon as every agent's belief holds
at least ``localization_mass`` (0.9) of its mass within ``localization_radius`` (1.0 unit) of its
own MMSE estimate.

**Infos** (``infos[agent]``, the same keys after ``reset`` and every ``step``; numbers and numpy
arrays only, so RL frameworks batch them as they are): ``"vehicle_states"`` (read-only
``(A, 3)``), ``"agent_index"``, ``"belief_recovered"``, ``"ess"``, ``"entropy"``,
``"posterior_mass"``, ``"separation_violations"``; with ``belief_in_infos=True`` also
``"belief"`` (the BeliefView the scripted planners read). ``env.unwrapped.belief(agent)`` returns
an agent's BeliefView either way (``ValueError`` for an unknown agent, ``RuntimeError`` before
``reset``). The true target is only available through ``env.unwrapped.true_target()``.

**Centralised state.** ``env.state()`` (float32, in ``env.state_space``; slices in
``env.unwrapped.config.state_layout``): every vehicle's state, every agent's belief grid, MMSE
estimate and posterior mass (what a centralised critic such as MAPPO's should see; never the
true target). Layout and bounds: :mod:`infoseek.envs.spaces`. ``state()`` before ``reset()``
raises ``RuntimeError``.


### Arguments

```python
infoseek.envs.bearings_v0.parallel_env(
    n_agents=4, n_particles=2000, max_cycles=60, dt=1.0,
    sensor_kwargs={"sigma": 0.1}, vehicle_kwargs={"speed": 1.0, "max_turn_rate": 0.5},
    target_motion="stationary", target_motion_kwargs=None, domain_size=None,
    start_center=(5.0, 5.0), start_spacing=None, start_positions=None, min_separation=1.0,
    action_type="continuous", n_discrete_actions=5, separation_penalty=1.0,
    resample_threshold=1.0, roughening=0.2, tempering_ess=None, filter_max_snr=None,
    entropy_bins=None, belief_grid=(8, 8), belief_moments=False,
    localization_radius=1.0, localization_mass=0.9, terminate_on_localization=False,
    comm_range=inf, message_loss=0.0, belief_in_infos=False, render_mode=None,
)
```

* `sensor` ("bearing"), `vehicle` ("airplane"), `target_space` ("planar"): the
  components, by registry name or instance (changing them makes a different environment;
  `name` ("bearings_v0") is the name reported in `metadata`).
* `n_agents` (4): number of airplanes, >= 1.
* `n_particles` (2000): particles in each agent's belief, >= 100 (fewer cannot represent the
  uniform prior, and the posterior-mass metrics of a tiny belief are meaningless).
* `max_cycles` (60): steps before truncation.
* `dt` (1.0 s): time step (> 0).
* `sensor_kwargs` ({"sigma": 0.1}): `BearingSensor` arguments; `sigma` is the bearing noise
  standard deviation in rad.
* `vehicle_kwargs` ({"speed": 1.0, "max_turn_rate": 0.5}): `Airplane` arguments; speed in
  units/s, turn-rate bound in rad/s.
* `target_motion` ("stationary"), `target_motion_kwargs` (None): target motion model by name
  (``"stationary"``, ``"random_walk"``) or instance; the beliefs predict with the same model.
* `domain_size` (None = (40.0, 40.0) units): width and height of the search domain;
  `target_space` ("planar") may instead be a `TargetSpace` instance (then leave
  `domain_size` None).
* `start_center` ((5.0, 5.0) units), `start_spacing` (None = max(2, 2 min_separation) units):
  the airplanes start on a compact grid around `start_center` (shifted into the domain if
  needed); `start_positions` ((n_agents, 2) array, None) overrides it.
* `min_separation` (1.0 unit): the separation d-bar of eq. 2 (>= 0); start positions closer
  than this are rejected.
* `action_type` ("continuous" | "discrete"), `n_discrete_actions` (5, >= 2).
* `separation_penalty` (1.0 reward units per violated pair per step, >= 0).
* `resample_threshold` (1.0: resample after every informative update, as the paper; 0: never),
  `roughening` (0.2; 0 disables), `entropy_bins` (None: the adaptive grid of
  :mod:`infoseek.envs.entropy`; a pair: a fixed grid): belief options.
* `tempering_ess` (None: 0.1 for the stationary target, 0 for a moving one; 0 disables):
  progressive correction of updates that would leave fewer than 10% effective particles, whose
  Metropolis moves target the exact posterior given every observation the belief kept (see
  :mod:`infoseek.envs.belief`); a value > 0 with a moving target is a `ValueError`.
* `filter_max_snr` (None): filter noise floor for sensors that support it (the beacon; see
  :mod:`infoseek.envs.search_env`); the bearing sensor does not, so it must stay `None`.
* `belief_grid` ((8, 8)): coarse belief-mass grid in the observation.
* `belief_moments` (False): append the belief's spread and posterior mass to every
  observation (what a policy needs once the belief is smaller than a grid cell).
* `localization_radius` (1.0 unit), `localization_mass` (0.9), `terminate_on_localization`
  (False).
* `comm_range` (inf units): observations are shared only between vehicles at most this far
  apart; `message_loss` (0.0): probability that each message is lost. An agent always
  receives its own observation.
* `belief_in_infos` (False): also put each agent's BeliefView in its infos (for the planners).
* `render_mode` (None | "rgb_array" | "human"): draws agent 0's particles shaded by weight, the
  vehicle trails, the MMSE estimate (X) and the true target (square).

Unknown keywords raise ``ValueError`` listing the valid ones; impossible values raise
``ValueError``/``TypeError`` naming the argument. Randomness comes only from ``reset(seed)``.

### Version history

* v0: initial release.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pettingzoo import AECEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from infoseek.envs.registration import registry
from infoseek.envs.search_env import InformationSeekingEnv

__all__ = ["DEFAULT_CONFIG", "env", "parallel_env", "raw_env"]

DEFAULT_CONFIG: Mapping[str, Any] = registry["bearings_v0"].kwargs
"""Defaults of this version; any key of :class:`InformationSeekingEnv` may be overridden."""


def parallel_env(**kwargs: Any) -> InformationSeekingEnv:
    """The parallel environment (see the module manual for every keyword)."""
    return InformationSeekingEnv(**{**DEFAULT_CONFIG, **kwargs})


def raw_env(**kwargs: Any) -> AECEnv:
    """The AEC version without the order-enforcing wrapper."""
    return parallel_to_aec_wrapper(parallel_env(**kwargs))


def env(**kwargs: Any) -> AECEnv:
    """The AEC version (agents act in index order, one ``step`` each per cycle).

    Only PettingZoo's ``OrderEnforcingWrapper`` is added: the environment itself clips
    continuous actions and raises ``ValueError`` naming the agent for malformed ones, so the
    assert-based out-of-bounds wrappers would only weaken the error messages.
    """
    return OrderEnforcingWrapper(raw_env(**kwargs))
