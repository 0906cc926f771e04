"""Behaviour of the information-seeking environments (bearings_v0, beacon_v0, the generic base)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from pettingzoo import AECEnv

import infoseek.envs
from infoseek.envs import bearings_v0
from infoseek.envs.belief import BeliefView
from infoseek.envs.registration import EnvSpec, registry
from infoseek.envs.search_env import INFO_KEYS, InformationSeekingEnv

ENV_IDS = ("bearings_v0", "beacon_v0", "beacon_v1")
SMALL = {"n_particles": 300, "max_cycles": 8}


def _random_actions(env, rng: np.random.Generator) -> dict:
    actions = {}
    for agent in env.agents:
        space = env.action_space(agent)
        if env.config.action_type == "discrete":
            actions[agent] = int(rng.integers(space.n))
        else:
            actions[agent] = rng.uniform(space.low, space.high).astype(np.float32)
    return actions


def _logsumexp(values: np.ndarray) -> float:
    top = np.max(values)
    return float(top + np.log(np.sum(np.exp(values - top))))


# --------------------------------------------------------------------------- registry and make
def test_registry_specs_are_frozen_and_point_at_the_versioned_modules() -> None:
    for env_id in ENV_IDS:
        spec = registry[env_id]
        assert isinstance(spec, EnvSpec)
        assert spec.id == env_id
        assert spec.entry_point == f"infoseek.envs.{env_id}:parallel_env"
        with pytest.raises(dataclasses.FrozenInstanceError):
            spec.id = "other"  # type: ignore[misc]
    assert infoseek.envs.registry is registry


def test_make_returns_parallel_by_default_and_aec_on_request() -> None:
    par = infoseek.envs.make("bearings_v0", n_agents=2, **SMALL)
    assert isinstance(par, InformationSeekingEnv)
    assert par.config.n_agents == 2 and par.max_cycles == 8
    aec = infoseek.envs.make("beacon_v0", parallel=False, n_agents=3, **SMALL)
    assert isinstance(aec, AECEnv)
    assert aec.unwrapped.config.n_agents == 3
    assert aec.unwrapped.config.sensor.name == "beacon"


def test_make_unknown_id_lists_the_valid_ids() -> None:
    with pytest.raises(ValueError, match="bearings_v0") as error:
        infoseek.envs.make("bearing_v0")
    assert "beacon_v0" in str(error.value)


def test_versioned_defaults_follow_the_paper() -> None:
    bear = infoseek.envs.make("bearings_v0")
    beac = infoseek.envs.make("beacon_v0")
    for env in (bear, beac):
        assert env.config.n_agents == 4 and env.config.n_particles == 2000 and env.config.dt == 1.0
        assert env.config.min_separation == 1.0 and env.config.localization_radius == 1.0
        assert tuple(env.config.space.low[:2]) == (0.0, 0.0) and tuple(
            env.config.space.high[:2]
        ) == (40.0, 40.0)
        assert env.config.action_type == "continuous" and env.config.discrete_controls is None
    assert bear.max_cycles == 60 and beac.max_cycles == 40
    assert (
        bear.config.space.dim == 2
        and bear.config.vehicle.name == "airplane"
        and bear.config.sensor.name == "bearing"
    )
    assert (
        beac.config.space.dim == 3
        and beac.config.vehicle.name == "quadrotor"
        and beac.config.sensor.name == "beacon"
    )
    assert beac.config.space.periodic[2] and beac.config.space.high[2] == pytest.approx(2 * np.pi)


# --------------------------------------------------------------------------- episode structure
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_default_four_agent_episode_with_random_actions_runs_to_truncation(env_id: str) -> None:
    env = infoseek.envs.make(env_id)
    rng = np.random.default_rng(3)
    _, infos = env.reset(seed=3)
    assert set(infos) == set(env.possible_agents)
    steps = 0
    while env.agents:
        _, rewards, terms, truncs, infos = env.step(_random_actions(env, rng))
        steps += 1
        assert all(isinstance(r, float) and math.isfinite(r) for r in rewards.values())
    assert steps == env.max_cycles
    assert all(truncs.values()) and not any(terms.values())
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_infos_have_exactly_the_contract_keys(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=3, **SMALL)
    _, infos = env.reset(seed=0)
    for stage in range(2):
        for i, agent in enumerate(env.possible_agents):
            info = infos[agent]
            assert tuple(info) == INFO_KEYS
            assert "belief" not in info  # numbers and arrays only, for RL frameworks
            assert isinstance(env.belief(agent), BeliefView)
            assert info["agent_index"] == i
            assert info["vehicle_states"].shape == (3, env.config.vehicle.state_dim)
            assert not info["vehicle_states"].flags.writeable
            assert isinstance(info["belief_recovered"], bool)
            assert isinstance(info["separation_violations"], int)
            assert 0.0 <= info["posterior_mass"] <= 1.0
            assert 1.0 <= info["ess"] <= env.config.n_particles + 1e-6
            belief = env.agent_belief(agent)
            assert info["entropy"] == pytest.approx(belief.entropy())
            assert info["posterior_mass"] == pytest.approx(
                belief.mass_within(env.config.localization_radius, belief.mmse())
            )
        if stage == 0:
            _, _, _, _, infos = env.step(_random_actions(env, np.random.default_rng(0)))


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("n_agents", [1, 3])
def test_observation_follows_the_documented_layout(env_id: str, n_agents: int) -> None:
    env = infoseek.envs.make(env_id, n_agents=n_agents, **SMALL)
    env.reset(seed=5)
    obs, _, _, _, infos = env.step(_random_actions(env, np.random.default_rng(5)))
    layout = env.config.observation_layout
    assert list(layout) == [
        "own_state",
        "others_relative_positions",
        "belief_grid",
        "mmse_estimate",
    ]
    size = env.observation_space("vehicle_0").shape[0]
    assert layout["mmse_estimate"].stop == size
    assert all(env.observation_space(a) == env.observation_space("vehicle_0") for a in env.agents)
    states = infos["vehicle_0"]["vehicle_states"]
    positions = states[:, :2]
    for i, agent in enumerate(env.possible_agents):
        o = obs[agent]
        assert o.dtype == np.float32 and o.shape == (size,)
        assert env.observation_space(agent).contains(o)
        np.testing.assert_allclose(o[layout["own_state"]], states[i], rtol=1e-6, atol=1e-5)
        others = [positions[j] - positions[i] for j in range(n_agents) if j != i]
        expected = np.concatenate(others) if others else np.zeros(0)
        np.testing.assert_allclose(o[layout["others_relative_positions"]], expected, atol=1e-5)
        belief = env.agent_belief(agent)
        np.testing.assert_allclose(
            o[layout["belief_grid"]], belief.mass_grid((8, 8)).ravel(), atol=1e-6
        )
        np.testing.assert_allclose(o[layout["mmse_estimate"]], belief.mmse(), rtol=1e-6, atol=1e-5)


# --------------------------------------------------------------------------- rewards
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reward_is_the_entropy_reduction_minus_the_separation_penalty(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=4, separation_penalty=0.7, **SMALL)
    _, infos = env.reset(seed=11)
    rng = np.random.default_rng(11)
    initial = {a: infos[a]["entropy"] for a in env.possible_agents}
    total = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        previous = {a: infos[a]["entropy"] for a in env.possible_agents}
        _, rewards, _, _, infos = env.step(_random_actions(env, rng))
        for agent, reward in rewards.items():
            penalty = 0.7 * infos[agent]["separation_violations"]
            assert reward == pytest.approx(previous[agent] - infos[agent]["entropy"] - penalty)
            total[agent] += reward + penalty
    for agent in env.possible_agents:  # the information part telescopes to H_0 - H_T
        assert total[agent] == pytest.approx(initial[agent] - infos[agent]["entropy"])


def test_separation_penalty_applies_when_vehicles_are_forced_together() -> None:
    # quadrotors 2.5 apart accelerate towards each other, then coast: they cross mid-step 2
    env = infoseek.envs.make(
        "beacon_v0",
        n_agents=3,
        start_positions=[(10.0, 10.0), (12.5, 10.0), (30.0, 30.0)],
        separation_penalty=2.5,
        min_separation=1.0,
        **SMALL,
    )
    _, infos = env.reset(seed=2)
    assert [infos[a]["separation_violations"] for a in env.agents] == [0, 0, 0]
    push = {"vehicle_0": [1.0, 0.0], "vehicle_1": [-1.0, 0.0], "vehicle_2": [0.0, 0.0]}
    coast = dict.fromkeys(env.agents, [0.0, 0.0])
    saw_violation = False
    for actions in (push, coast):
        before = {a: infos[a]["entropy"] for a in env.agents}
        _, rewards, _, _, infos = env.step({a: np.array(u) for a, u in actions.items()})
        positions = infos["vehicle_0"]["vehicle_states"][:, :2]
        distance = np.linalg.norm(positions[:, None] - positions[None], axis=-1)
        np.fill_diagonal(distance, np.inf)
        brute = (distance < 1.0).sum(axis=1)
        for i, agent in enumerate(env.possible_agents):
            assert infos[agent]["separation_violations"] == brute[i]
            gain = before[agent] - infos[agent]["entropy"]
            assert rewards[agent] == pytest.approx(gain - 2.5 * brute[i])
        saw_violation |= bool(brute[0] == 1 and brute[1] == 1 and brute[2] == 0)
    assert saw_violation


# --------------------------------------------------------------------------- truth stays hidden
def _arrays_in(value) -> list[np.ndarray]:
    if isinstance(value, dict):
        return [a for v in value.values() for a in _arrays_in(v)]
    if isinstance(value, (list, tuple)):
        return [a for v in value for a in _arrays_in(v)]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return [a for f in dataclasses.fields(value) for a in _arrays_in(getattr(value, f.name))]
    if isinstance(value, np.ndarray):
        return [value]
    if isinstance(value, (float, int, np.floating)):
        return [np.array([value], dtype=np.float64)]
    return []


def _contains_coordinate(arrays: list[np.ndarray], coordinate: float) -> bool:
    return any(
        np.any(a.astype(np.float64) == coordinate)
        or np.any(a.astype(np.float64) == float(np.float32(coordinate)))
        for a in arrays
        if a.dtype.kind == "f"
    )


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_true_target_never_appears_in_observations_or_infos(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=2, **SMALL)
    obs, infos = env.reset(seed=21)
    target = env.true_target()
    rng = np.random.default_rng(21)
    for _ in range(3):
        arrays = _arrays_in(obs) + _arrays_in(infos)
        assert len(arrays) > 10
        for coordinate in target:
            assert not _contains_coordinate(arrays, coordinate)
        obs, _, _, _, infos = env.step(_random_actions(env, rng))
    # the scan itself does detect a leaked coordinate
    assert _contains_coordinate(_arrays_in({"leak": target.copy()}), target[0])
    # true_target() is a copy
    leaked = env.true_target()
    leaked[:] = -1.0
    np.testing.assert_array_equal(env.true_target(), target)


# --------------------------------------------------------------------------- communication
def _step_and_recompute(env, seed: int):
    """One step; returns, per agent, its belief's log-weights and the two recomputations."""
    env.reset(seed=seed)
    priors = {a: np.array(env.agent_belief(a).log_weights) for a in env.agents}
    particles = {a: np.array(env.agent_belief(a).particles) for a in env.agents}
    _, _, _, _, infos = env.step(_random_actions(env, np.random.default_rng(seed)))
    z = np.array(env.last_measurements)
    poses = infos["vehicle_0"]["vehicle_states"][:, :2]
    # the beliefs' likelihood: the sensor's, with beacon_v0's filter noise floor (max_snr)
    filter_model = env.config.filter_sensor
    results = {}
    for i, agent in enumerate(env.possible_agents):
        loglik = filter_model.log_likelihood(z, poses, particles[agent])
        own = priors[agent] + loglik[i]
        everyone = priors[agent] + loglik.sum(axis=0)
        results[agent] = (
            np.array(env.belief(agent).log_weights),
            own - _logsumexp(own),
            everyone - _logsumexp(everyone),
        )
    return results


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_full_communication_beliefs_incorporate_every_observation(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=3, resample_threshold=0.0, roughening=0.0, **SMALL)
    results = _step_and_recompute(env, seed=8)
    assert np.all(env.last_reception)
    for actual, own_only, everyone in results.values():
        np.testing.assert_allclose(actual, everyone, atol=1e-8)
        assert np.max(np.abs(actual - own_only)) > 1e-3  # other agents' data really mattered


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_total_message_loss_leaves_each_agent_with_its_own_observation(env_id: str) -> None:
    env = infoseek.envs.make(
        env_id, n_agents=3, resample_threshold=0.0, roughening=0.0, message_loss=1.0, **SMALL
    )
    results = _step_and_recompute(env, seed=8)
    np.testing.assert_array_equal(env.last_reception, np.eye(3, dtype=bool))
    for actual, own_only, everyone in results.values():
        np.testing.assert_allclose(actual, own_only, atol=1e-8)
        assert np.max(np.abs(actual - everyone)) > 1e-3


def test_beliefs_diverge_under_message_loss_but_stay_close_with_full_comms() -> None:
    # Largest total-variation distance between two agents' 8 x 8 position-mass grids after
    # three steps. Full comms: the agents filter the same data (differences are Monte Carlo
    # noise of their own particle streams). No comms: each agent sees only its own bearings.
    def max_tv(message_loss: float, seed: int) -> float:
        env = infoseek.envs.make(
            "bearings_v0", n_agents=4, message_loss=message_loss, n_particles=2000, max_cycles=3
        )
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        while env.agents:
            env.step(_random_actions(env, rng))
        grids = np.stack(
            [
                env.agent_belief(a).mass_grid((8, 8)).ravel()
                for a in env.agents or env.possible_agents
            ]
        )
        return max(
            0.5 * float(np.abs(grids[i] - grids[j]).sum())
            for i in range(4)
            for j in range(i + 1, 4)
        )

    shared = [max_tv(0.0, seed) for seed in range(3)]
    isolated = [max_tv(1.0, seed) for seed in range(3)]
    assert all(i > s for i, s in zip(isolated, shared, strict=True))
    assert np.mean(isolated) > 2.0 * np.mean(shared)


def test_comm_range_and_message_loss_decide_who_receives_what() -> None:
    env = infoseek.envs.make(
        "beacon_v0",
        n_agents=9,
        comm_range=2.5,
        start_spacing=2.0,
        message_loss=0.3,
        n_particles=100,
        max_cycles=40,
    )
    env.reset(seed=1)
    hover = {a: np.zeros(2) for a in env.agents}  # a 3 x 3 grid at rest: 12 neighbour pairs
    received, possible = 0, 0
    while env.agents:
        _, _, _, _, infos = env.step(hover)
        positions = infos["vehicle_0"]["vehicle_states"][:, :2]
        in_range = np.linalg.norm(positions[:, None] - positions[None], axis=-1) <= 2.5
        reception = env.last_reception
        assert np.all(np.diag(reception))
        assert not np.any(reception & ~in_range)  # nothing arrives from out of range
        off_diagonal = in_range & ~np.eye(9, dtype=bool)
        received += int(reception[off_diagonal].sum())
        possible += int(off_diagonal.sum())
    assert possible == 40 * 24
    assert received / possible == pytest.approx(0.7, abs=0.05)  # binomial sd 0.015


# --------------------------------------------------------------------------- determinism
def _rollout(env, seed: int, steps: int):
    obs, infos = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    trace = [(obs, infos, env.true_target())]
    for _ in range(steps):
        obs, rewards, _, _, infos = env.step(_random_actions(env, rng))
        trace.append((obs, rewards, infos, env.unwrapped.belief("vehicle_1").particles))
    return trace


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray):
        return np.array_equal(a, b)
    return a == b


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_gives_identical_episodes_and_another_seed_does_not(env_id: str) -> None:
    first = _rollout(infoseek.envs.make(env_id, n_agents=2, **SMALL), 7, 4)
    second = _rollout(infoseek.envs.make(env_id, n_agents=2, **SMALL), 7, 4)
    other = _rollout(infoseek.envs.make(env_id, n_agents=2, **SMALL), 8, 4)
    assert _same(first, second)
    assert not np.array_equal(first[0][2], other[0][2])
    assert not _same(first[-1][0], other[-1][0])


def test_unseeded_resets_after_a_seeded_reset_are_reproducible() -> None:
    def targets() -> list[np.ndarray]:
        env = infoseek.envs.make("bearings_v0", n_agents=1, **SMALL)
        env.reset(seed=3)
        found = [env.true_target()]
        for _ in range(2):
            env.reset()
            found.append(env.true_target())
        return found

    a, b = targets(), targets()
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[0], a[1]) and not np.array_equal(a[1], a[2])


# --------------------------------------------------------------------------- actions
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_continuous_actions_outside_the_bounds_are_clipped(env_id: str) -> None:
    envs = [infoseek.envs.make(env_id, n_agents=2, **SMALL) for _ in range(2)]
    high = envs[0].config.vehicle.control_high
    low = envs[0].config.vehicle.control_low
    wild = {"vehicle_0": 10.0 * high + 3.0, "vehicle_1": 10.0 * low - 3.0}
    tame = {"vehicle_0": high.copy(), "vehicle_1": low.copy()}
    states = []
    for env, actions in zip(envs, (wild, tame), strict=True):
        env.reset(seed=0)
        _, _, _, _, infos = env.step(actions)
        states.append(infos["vehicle_0"]["vehicle_states"])
    np.testing.assert_array_equal(states[0], states[1])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_discrete_action_k_applies_control_table_row_k(env_id: str) -> None:
    k = 3
    disc = infoseek.envs.make(
        env_id, n_agents=2, action_type="discrete", n_discrete_actions=k, **SMALL
    )
    cont = infoseek.envs.make(env_id, n_agents=2, **SMALL)
    table = disc.config.discrete_controls
    control_dim = disc.config.vehicle.control_dim
    assert table.shape == (k**control_dim, control_dim)
    assert disc.action_space("vehicle_0").n == k**control_dim
    for axis in range(control_dim):  # every axis takes k evenly spaced values between the bounds
        np.testing.assert_allclose(
            np.unique(table[:, axis]),
            np.linspace(
                disc.config.vehicle.control_low[axis], disc.config.vehicle.control_high[axis], k
            ),
        )
    assert len(np.unique(table, axis=0)) == len(table)
    disc.reset(seed=1)
    cont.reset(seed=1)
    choice = {"vehicle_0": len(table) - 1, "vehicle_1": np.int64(1)}
    _, _, _, _, infos_d = disc.step(choice)
    _, _, _, _, infos_c = cont.step({a: table[int(c)] for a, c in choice.items()})
    np.testing.assert_array_equal(
        infos_d["vehicle_0"]["vehicle_states"], infos_c["vehicle_0"]["vehicle_states"]
    )


def _continuous_env():
    env = bearings_v0.parallel_env(n_agents=2, **SMALL)
    env.reset(seed=0)
    return env


def _discrete_env():
    env = bearings_v0.parallel_env(n_agents=2, action_type="discrete", **SMALL)
    env.reset(seed=0)
    return env


ok = np.zeros(1, dtype=np.float32)


@pytest.mark.parametrize(
    ("make_env", "actions", "error", "pattern"),
    [
        (
            _continuous_env,
            {"vehicle_0": ok, "vehicle_1": np.zeros(3)},
            ValueError,
            "vehicle_1.*shape",
        ),
        (
            _continuous_env,
            {"vehicle_0": ok, "vehicle_1": np.zeros((1, 1))},
            ValueError,
            "vehicle_1",
        ),
        (
            _continuous_env,
            {"vehicle_0": np.array([np.nan]), "vehicle_1": ok},
            ValueError,
            "vehicle_0.*finite",
        ),
        (
            _continuous_env,
            {"vehicle_0": ok, "vehicle_1": np.array([np.inf])},
            ValueError,
            "vehicle_1.*finite",
        ),
        (_continuous_env, {"vehicle_0": ok, "vehicle_1": "left"}, TypeError, "vehicle_1"),
        (
            _continuous_env,
            {"vehicle_0": ok, "vehicle_1": ok, "vehicle_7": ok},
            ValueError,
            "vehicle_7",
        ),
        (_continuous_env, {"vehicle_0": ok}, ValueError, "vehicle_1"),
        (_continuous_env, [ok, ok], TypeError, "dict"),
        (_discrete_env, {"vehicle_0": 0, "vehicle_1": 5}, ValueError, r"vehicle_1.*\[0, 5\)"),
        (_discrete_env, {"vehicle_0": -1, "vehicle_1": 0}, ValueError, "vehicle_0"),
        (_discrete_env, {"vehicle_0": 1.0, "vehicle_1": 0}, TypeError, "vehicle_0.*integer"),
        (_discrete_env, {"vehicle_0": True, "vehicle_1": 0}, TypeError, "vehicle_0"),
    ],
)
def test_bad_actions_raise_naming_the_agent(make_env, actions, error, pattern) -> None:
    env = make_env()
    before = np.array(env.vehicle_states)
    with pytest.raises(error, match=pattern):
        env.step(actions)
    np.testing.assert_array_equal(env.vehicle_states, before)  # nothing moved
    assert env.cycles == 0


# --------------------------------------------------------------------------- configuration
@pytest.mark.parametrize(
    ("kwargs", "error", "pattern"),
    [
        ({"n_agents": 0}, ValueError, "n_agents"),
        ({"n_agents": 2.5}, TypeError, "n_agents"),
        ({"n_particles": 0}, ValueError, "n_particles"),
        ({"n_particles": 99}, ValueError, r"n_particles must be an integer >= 100"),
        ({"max_cycles": 0}, ValueError, "max_cycles"),
        ({"min_separation": -1.0}, ValueError, "min_separation"),
        ({"dt": -1.0}, ValueError, "dt"),
        ({"dt": 0.0}, ValueError, "dt"),
        ({"dt": float("nan")}, ValueError, "dt"),
        ({"message_loss": 1.5}, ValueError, "message_loss"),
        ({"message_loss": -0.1}, ValueError, "message_loss"),
        ({"comm_range": -1.0}, ValueError, "comm_range"),
        ({"separation_penalty": -1.0}, ValueError, "separation_penalty"),
        ({"resample_threshold": 2.0}, ValueError, "resample_threshold"),
        ({"localization_radius": 0.0}, ValueError, "localization_radius"),
        ({"localization_mass": 0.0}, ValueError, "localization_mass"),
        ({"action_type": "both"}, ValueError, "action_type"),
        ({"n_discrete_actions": 1, "action_type": "discrete"}, ValueError, "n_discrete_actions"),
        ({"belief_grid": (0, 8)}, ValueError, "belief_grid"),
        ({"render_mode": "ansi"}, ValueError, "render_mode"),
        (
            {"start_positions": [(5.0, 5.0), (5.5, 5.0)], "n_agents": 2},
            ValueError,
            "min_separation",
        ),
        (
            {"start_positions": [(5.0, 5.0)], "n_agents": 2},
            ValueError,
            r"start_positions.*\(2, 2\)",
        ),
        ({"start_positions": [(5.0, 5.0), (50.0, 5.0)], "n_agents": 2}, ValueError, "vehicle_1"),
        ({"start_spacing": 0.5}, ValueError, "start_spacing"),
        ({"sensor_kwargs": 3}, TypeError, "sensor_kwargs"),
        ({"target_space": "cube"}, ValueError, "target_space"),
        ({"target_space": "planar_with_orientation"}, ValueError, "dim"),
    ],
)
def test_impossible_configurations_raise_naming_the_argument(kwargs, error, pattern) -> None:
    with pytest.raises(error, match=pattern):
        bearings_v0.parallel_env(**kwargs)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_unknown_configuration_keys_are_rejected_listing_the_valid_ones(env_id: str) -> None:
    with pytest.raises(ValueError, match="n_agent") as error:
        infoseek.envs.make(env_id, n_agent=3)
    message = str(error.value)
    for valid in ("n_agents", "n_particles", "message_loss", "sensor_kwargs", "render_mode"):
        assert valid in message


def test_default_start_cluster_is_compact_separated_and_inside_the_domain() -> None:
    for n_agents in (1, 2, 4, 10):
        env = bearings_v0.parallel_env(n_agents=n_agents, **SMALL)
        positions = env.config.start_positions
        np.testing.assert_allclose(positions.mean(axis=0), (5.0, 5.0), atol=1.0)
        distance = np.linalg.norm(positions[:, None] - positions[None], axis=-1)
        np.fill_diagonal(distance, np.inf)
        if n_agents > 1:
            assert distance.min() > env.config.min_separation
            assert distance.min() <= 2.0 + 1e-12  # close together, as in the paper
    shifted = bearings_v0.parallel_env(n_agents=9, start_center=(0.0, 0.0), **SMALL)
    assert shifted.config.start_positions.min() >= 0.0  # shifted into the domain, not rejected


def test_termination_on_localisation_ends_the_episode_for_everyone() -> None:
    env = bearings_v0.parallel_env(
        n_agents=2, terminate_on_localization=True, localization_radius=60.0, **SMALL
    )
    env.reset(seed=0)
    _, _, terms, truncs, infos = env.step({a: np.zeros(1) for a in env.agents})
    assert all(info["posterior_mass"] >= 0.9 for info in infos.values())
    assert all(terms.values()) and not any(truncs.values())
    assert env.agents == []
    patient = bearings_v0.parallel_env(n_agents=2, localization_radius=60.0, **SMALL)
    patient.reset(seed=0)
    _, _, terms, _, _ = patient.step({a: np.zeros(1) for a in patient.agents})
    assert not any(terms.values()) and patient.agents


# --------------------------------------------------------------------------- rendering
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rgb_array_render_returns_frames_that_follow_the_episode(env_id: str) -> None:
    env = infoseek.envs.make(env_id, render_mode="rgb_array", n_agents=3, **SMALL)
    env.reset(seed=0)
    first = env.render()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    assert first.shape[0] > 100 and first.shape[1] > 100
    figure = env.unwrapped.renderer.figure
    rng = np.random.default_rng(0)
    for _ in range(3):
        env.step(_random_actions(env, rng))
    later = env.render()
    assert later.shape == first.shape
    assert env.unwrapped.renderer.figure is figure  # the figure is reused
    assert np.any(later != first)
    assert (later < 128).mean() > 0.001  # something dark is drawn (particles, box, markers)
    # the true target is drawn as a red square: strongly red pixels exist
    red = (later[..., 0] > 200) & (later[..., 1] < 80) & (later[..., 2] < 80)
    assert red.sum() > 10
    env.close()


def test_render_without_render_mode_returns_none_and_keeps_no_figure() -> None:
    env = bearings_v0.parallel_env(n_agents=1, **SMALL)
    env.reset(seed=0)
    env.step({"vehicle_0": np.zeros(1)})
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None
    assert env.unwrapped.renderer is None and env._trails == []


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_module_manual_documents_every_configuration_key(env_id: str) -> None:
    manual = getattr(infoseek.envs, env_id).__doc__
    missing = [key for key in InformationSeekingEnv.config_keys() if f"`{key}`" not in manual]
    assert not missing


def test_reset_options_place_the_target_and_reject_bad_keys() -> None:
    env = infoseek.envs.make("beacon_v0", n_agents=2, n_particles=100)
    env.reset(seed=3, options={"target": [30.0, 20.0, np.pi / 4]})
    np.testing.assert_allclose(env.unwrapped.true_target(), [30.0, 20.0, np.pi / 4])
    # The other streams are unchanged: the beliefs are the same as without the option.
    env.reset(seed=3, options={"target": [30.0, 20.0, np.pi / 4]})
    placed = env.unwrapped.belief("vehicle_0")
    env.reset(seed=3)
    assert placed == env.unwrapped.belief("vehicle_0")
    with pytest.warns(UserWarning, match="ignoring unknown keys"):
        env.reset(options={"targte": [1.0, 1.0, 0.0]})
    with pytest.raises(ValueError, match="outside the domain"):
        env.reset(options={"target": [50.0, 1.0, 0.0]})
    with pytest.raises(ValueError, match="3 finite numbers"):
        env.reset(options={"target": [1.0, 1.0]})


def test_settings_live_in_the_config_and_are_not_forwarded() -> None:
    """Issue 27: the env forwarded unknown attributes to its config, so setting one (as the
    harness's ``make_env`` did with ``belief_in_infos``) made an instance attribute that hid the
    config's value. The settings are read from ``env.config`` only."""
    env = infoseek.envs.make("bearings_v0", n_particles=100, belief_in_infos=False)
    base = env.unwrapped
    assert base.config.sensor.name == "bearing" and base.config.n_particles == 100
    for name in ("sensor", "vehicle", "space", "n_particles", "belief_in_infos"):
        assert not hasattr(base, name), name
    env.reset(seed=0)
    _, _, _, _, infos = env.step({a: env.action_space(a).sample() for a in env.agents})
    assert "belief" not in infos["vehicle_0"]  # the config decides, nothing else
    on = infoseek.envs.make("bearings_v0", n_particles=100, belief_in_infos=True)
    on.reset(seed=0)
    _, _, _, _, infos = on.step({a: on.action_space(a).sample() for a in on.agents})
    assert "belief" in infos["vehicle_0"]


def test_beacon_v1_is_beacon_v0_with_its_filter_settings() -> None:
    """beacon_v1 steps through the same numbers as beacon_v0 given v1's two filter settings
    (so a beacon_v0 store run with them is a beacon_v1 run), and differs from beacon_v0's
    defaults once a belief would have resampled differently."""
    settings = {"resample_threshold": 0.5, "tempering_ess": 0.5}
    assert {k: registry["beacon_v1"].kwargs[k] for k in settings} == settings
    runs = []
    for env_id, extra in (("beacon_v1", {}), ("beacon_v0", settings), ("beacon_v0", {})):
        env = infoseek.envs.make(env_id, n_agents=2, n_particles=300, max_cycles=12, **extra)
        env.reset(seed=3)
        rng = np.random.default_rng(0)
        masses = []
        while env.agents:
            _, _, _, _, infos = env.step(_random_actions(env, rng))
            masses.append([infos[a]["entropy"] for a in env.possible_agents])
        particles = np.asarray(env.unwrapped.belief("vehicle_0").particles)
        runs.append((np.asarray(masses), particles))
    v1, v0_with_settings, v0 = runs
    np.testing.assert_array_equal(v1[0], v0_with_settings[0])
    np.testing.assert_array_equal(v1[1], v0_with_settings[1])
    assert not np.array_equal(v1[1], v0[1])
