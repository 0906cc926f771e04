r"""
# Beacon v0

Quadrotors with avalanche-rescue beacon receivers search a 40 x 40 domain for a buried beacon
of unknown position and orientation (section IV-B and Fig. 2 of Hoffmann, Waslander & Tomlin
2006).

| Creation             | `infoseek.envs.make("beacon_v0")`, `beacon_v0.parallel_env()` |
|----------------------|----------------------------------------------------------------|
| Actions              | Continuous (default) or discrete                               |
| Parallel API         | Yes (native); AEC via `env()`                                  |
| Agents               | `["vehicle_0", ..., "vehicle_{n_agents-1}"]`                   |
| Agents (default)     | 4                                                              |
| Action shape         | `(2,)` acceleration `(ax, ay)` in `[-1, 1]^2`, or `Discrete(25)` |
| Observation shape    | `(2 * n_agents + 69,)` float32 (77 for 4 agents)               |
| Target state         | `(x, y, psi)`, uniform prior on `[0, 40) x [0, 40) x [0, 2 pi)` |

**Model.** Vehicle ``i`` is a quadrotor (state ``(x, y, vx, vy)``) whose commanded horizontal
acceleration ``(ax, ay)`` (proportional to its tilt) is bounded by ``max_accel`` per axis; the
velocity is then limited to ``max_speed`` in norm and the position integrated with the
trapezoidal rule (eq. 1). Every ``dt`` each vehicle measures the direction of the beacon's
horizontal magnetic near field (a dipole of orientation ``psi``) at its position: an axial angle
in ``[0, pi)`` computed from the field corrupted by Gaussian noise (the exact folded
projected-normal likelihood is used by the filters). The orientation ``psi`` is identifiable
only modulo ``pi``, so its MMSE estimate is the axial mean. The quadrotors start at rest,
clustered around ``(5, 5)``. Every agent keeps its own 2000-particle filter with the uniform
prior and, by default, incorporates every agent's observation every step; the filters apply a
documented noise floor to the (extremely sharp) near-field likelihood (`filter_max_snr`).

**Observations** (flat float32 Box, identical for every agent; slices in
``env.unwrapped.config.observation_layout``):

| Slice name                  | Size             | Content                        | Bounds |
|-----------------------------|------------------|--------------------------------|--------|
| `own_state`                 | 4                | own `(x, y, vx, vy)`           | (1)    |
| `others_relative_positions` | `2 (n_agents-1)` | `x_j - x_i` for j != i, by index | (R) |
| `belief_grid`               | 64               | own belief's mass on 8 x 8 cells (2) | `[0, 1]` |
| `mmse_estimate`             | 3                | own MMSE estimate `(x, y, psi)` (3) | (4) |
| `belief_moments`            | 4 (optional)     | own belief's `(s_x, s_y, rho, mass)` (5) | (5) |

(1) x, y within the reachable box: the domain and the start positions grown on every side by
`max_speed * dt * max_cycles`; vx, vy in `[-max_speed, max_speed]`. (R) within plus or minus
the reachable box's width and height. Every bound is finite (:mod:`infoseek.envs.spaces`);
reassigning `max_cycles` rebuilds the spaces.
(2) position mass of each cell of a regular 8 x 8 grid over the domain, cell `[ix, iy]` at
flat index `ix * 8 + iy` (x index slowest).
(3) eq. 12, with the axial mean for `psi` (reported in `[0, pi)`).
(4) `[0, 40] x [0, 40] x [0, 2 pi]`.
(5) only with `belief_moments=True`: the standard deviations of the own belief's planar
position (within the domain's width and height), their correlation (`[-1, 1]`) and the
posterior mass within `localization_radius` of the MMSE estimate (`[0, 1]`); see
:mod:`infoseek.envs.spaces`.

**Actions.** ``action_type="continuous"``: a ``(2,)`` acceleration; values outside
``[-max_accel, max_accel]`` are clipped per axis, NaN/inf raise ``ValueError``.
``action_type="discrete"``: an integer ``k`` in ``[0, n_discrete_actions**2)`` meaning the
acceleration ``env.unwrapped.config.discrete_controls[k]`` (a ``n x n`` grid of evenly spaced values
per axis, ``ay`` varying fastest).

**Reward.** Per agent and step: the entropy reduction ``H_{t-1} - H_t`` of its own belief
(histogram estimate of eq. 6 on a grid adapted to the particles, nats; ``log(1600 * 2 pi) =
9.22`` at the uniform prior for any particle count; ``infos[agent]["entropy"]``), minus
``separation_penalty`` (1.0) per other vehicle closer than ``min_separation`` (1.0 unit, eq. 2).

**Termination / truncation.** Truncation after ``max_cycles`` steps (default 40). With
``terminate_on_localization=True`` every agent terminates as soon as every agent's belief holds
at least ``localization_mass`` (0.9) of its position mass within ``localization_radius``
(1.0 unit) of its own MMSE position.

**Infos** (``infos[agent]``, the same keys after ``reset`` and every ``step``; numbers and numpy
arrays only): ``"vehicle_states"`` (read-only ``(A, 4)``), ``"agent_index"``,
``"belief_recovered"``, ``"ess"``, ``"entropy"``, ``"posterior_mass"``,
``"separation_violations"``; with ``belief_in_infos=True`` also ``"belief"`` (the BeliefView the
planners read). ``env.unwrapped.belief(agent)`` returns it either way. The true beacon state is
only available through ``env.unwrapped.true_target()``.

**Centralised state.** ``env.state()`` (float32, in ``env.state_space``; slices in
``env.unwrapped.config.state_layout``): every vehicle's state, every agent's belief grid, MMSE
estimate and posterior mass (what a centralised critic such as MAPPO's should see; never the
true target). Layout and bounds: :mod:`infoseek.envs.spaces`. ``state()`` before ``reset()``
raises ``RuntimeError``.


### Arguments

```python
infoseek.envs.beacon_v0.parallel_env(
    n_agents=4, n_particles=2000, max_cycles=40, dt=1.0,
    sensor_kwargs={"moment": 1000.0, "noise_std": 1.0},
    vehicle_kwargs={"max_accel": 1.0, "max_speed": 2.0},
    target_motion="stationary", target_motion_kwargs=None, domain_size=None,
    start_center=(5.0, 5.0), start_spacing=None, start_positions=None, min_separation=1.0,
    action_type="continuous", n_discrete_actions=5, separation_penalty=1.0,
    resample_threshold=1.0, roughening=0.2, tempering_ess=0.0, filter_max_snr=5.0,
    entropy_bins=None, belief_grid=(8, 8), belief_moments=False,
    localization_radius=1.0, localization_mass=0.9, terminate_on_localization=False,
    comm_range=inf, message_loss=0.0, belief_in_infos=False, render_mode=None,
)
```

* `sensor` ("beacon"), `vehicle` ("quadrotor"), `target_space` ("planar_with_orientation"): the
  components, by registry name or instance (changing them makes a different environment;
  `name` ("beacon_v0") is the name reported in `metadata`).
* `n_agents` (4): number of quadrotors, >= 1.
* `n_particles` (2000): particles in each agent's belief, >= 100 (fewer cannot represent the
  uniform prior, and the posterior-mass metrics of a tiny belief are meaningless).
* `max_cycles` (40): steps before truncation.
* `dt` (1.0 s): time step (> 0).
* `sensor_kwargs` ({"moment": 1000.0, "noise_std": 1.0}): `BeaconSensor` arguments: the
  dipole moment scaling the field strength and the standard deviation of the additive field
  noise on each horizontal component (field units).
* `vehicle_kwargs` ({"max_accel": 1.0, "max_speed": 2.0}): `Quadrotor` arguments
  (units/s^2 per axis, units/s in norm).
* `target_motion` ("stationary"), `target_motion_kwargs` (None): target motion model by name
  or instance; the beliefs predict with the same model.
* `domain_size` (None = (40.0, 40.0) units); `target_space` ("planar_with_orientation") may be a
  `TargetSpace` instance instead (leave `domain_size` None).
* `start_center` ((5.0, 5.0) units), `start_spacing` (None = max(2, 2 min_separation) units),
  `start_positions` ((n_agents, 2) array, None): initial cluster as in bearings_v0.
* `min_separation` (1.0 unit): d-bar of eq. 2 (>= 0).
* `action_type` ("continuous" | "discrete"), `n_discrete_actions` (5 per axis, >= 2).
* `separation_penalty` (1.0 per violated pair per step, >= 0).
* `resample_threshold` (1.0), `roughening` (0.2), `entropy_bins` (None: the adaptive
  grid of :mod:`infoseek.envs.entropy`; a triple: a fixed grid): belief options.
* `tempering_ess` (0.0: off): the beliefs' progressive correction (see
  :mod:`infoseek.envs.belief`). Off for this version, which was made when its Metropolis moves
  still treated the prior as locally flat (with a concentrated belief they drifted particles
  toward the current readings; the paper's Fig. 2 episode of `infoseek reproduce fig2` formed a
  false fix with it on). The moves now target the exact posterior given every kept
  observation; ``beacon_v1`` turns the correction on (with resampling at half the particles),
  which localises sooner (`docs/results/beacon_filter.md`).
* `filter_max_snr` (5.0): the filters' noise floor. Every belief evaluates the beacon
  likelihood as if the field noise were inflated wherever the signal-to-noise ratio
  ``|H| / noise_std`` exceeds 5 (angular std floor ~0.2 rad), because within a few units of the
  beacon the exact likelihood is far sharper than the 2000 particles can resolve (see
  :mod:`infoseek.envs.search_env`, "Filter noise floor"). The measurements are exact; the
  planners score with the filters' likelihood, floor included (``Planner.from_env`` copies
  ``env.unwrapped.config.filter_sensor``), so they plan with what the beliefs apply. `None`
  evaluates the exact likelihood in the filters, and so in the planners, as well (the floor is
  a filter setting that the paper does not specify, a documented deviation).
* `belief_moments` (False): append the belief's spread and posterior mass to every
  observation. `belief_grid` ((8, 8)); `localization_radius` (1.0 unit); `localization_mass` (0.9);
  `terminate_on_localization` (False).
* `comm_range` (inf units), `message_loss` (0.0): communication model; an agent always
  receives its own observation.
* `belief_in_infos` (False): also put each agent's BeliefView in its infos (for the planners).
* `render_mode` (None | "rgb_array" | "human"): agent 0's particles as short lines along their
  orientation, darker for heavier weights (as Fig. 2), the vehicle trails, the MMSE estimate
  (X) and the true beacon (square).

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

DEFAULT_CONFIG: Mapping[str, Any] = registry["beacon_v0"].kwargs
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
    continuous actions and raises ``ValueError`` naming the agent for malformed ones.
    """
    return OrderEnforcingWrapper(raw_env(**kwargs))
