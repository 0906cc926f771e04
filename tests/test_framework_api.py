"""What RL frameworks rely on: infos of numbers and arrays with the same keys at reset and at
every step, the belief behind an accessor, a centralised ``state()``, finite observation bounds,
and a single-agent Gymnasium form registered with Gymnasium."""

from __future__ import annotations

import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gymnasium_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import infoseek.envs
from infoseek.envs.belief import BeliefView
from infoseek.envs.single_agent import SingleAgentSearchEnv

ENV_IDS = ["bearings_v0", "beacon_v0"]
SMALL = {"n_particles": 200, "max_cycles": 6}


def _random_actions(env, rng: np.random.Generator) -> dict:
    return {
        a: rng.uniform(env.action_space(a).low, env.action_space(a).high).astype(np.float32)
        for a in env.agents
    }


def _plain(value: object) -> bool:
    return isinstance(value, bool | int | float | np.ndarray | np.number | np.bool_)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_infos_hold_numbers_and_arrays_with_the_same_keys_throughout(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=3, **SMALL)
    _, infos = env.reset(seed=0)
    keys = {agent: set(info) for agent, info in infos.items()}
    rng = np.random.default_rng(0)
    while env.agents:
        for agent, info in infos.items():
            assert set(info) == keys[agent]
            assert all(_plain(v) for v in info.values()), {k: type(v) for k, v in info.items()}
        _, _, _, _, infos = env.step(_random_actions(env, rng))
    assert all(set(info) == keys[agent] for agent, info in infos.items())


def test_belief_in_infos_is_opt_in_and_equals_the_accessor() -> None:
    env = infoseek.envs.make("bearings_v0", n_agents=2, belief_in_infos=True, **SMALL)
    _, infos = env.reset(seed=1)
    for agent in env.agents:
        assert isinstance(infos[agent]["belief"], BeliefView)
        assert infos[agent]["belief"] == env.unwrapped.belief(agent)
    with pytest.raises(TypeError, match="belief_in_infos"):
        infoseek.envs.make("bearings_v0", belief_in_infos="yes")


def test_accessors_name_the_agent_and_ask_for_reset() -> None:
    env = infoseek.envs.make("bearings_v0", n_agents=2, **SMALL)
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        env.unwrapped.belief("vehicle_0")
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        env.unwrapped.state()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="'vehicle_7'"):
        env.unwrapped.belief("vehicle_7")


def _mass_grid(view: BeliefView, space, shape: tuple[int, int]) -> np.ndarray:
    """Independent computation: numpy's weighted 2-D histogram over the domain."""
    low, high = np.asarray(space.low)[:2], np.asarray(space.high)[:2]
    grid, _, _ = np.histogram2d(
        view.particles[:, 0],
        view.particles[:, 1],
        bins=shape,
        range=[[low[0], high[0]], [low[1], high[1]]],
        weights=view.weights,
    )
    return grid / grid.sum()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_state_is_every_vehicle_and_belief_summary_inside_state_space(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=3, **SMALL)
    base = env.unwrapped
    _, infos = env.reset(seed=2)
    rng = np.random.default_rng(2)
    while True:
        state = base.state()
        assert state.dtype == np.float32 and base.state_space.contains(state)
        layout = base.config.state_layout
        np.testing.assert_allclose(
            state[layout["vehicle_states"]], base.vehicle_states.ravel(), rtol=1e-6, atol=1e-5
        )
        grids = [
            _mass_grid(base.belief(a), base.config.space, base.config.belief_grid)
            for a in env.possible_agents
        ]
        np.testing.assert_allclose(
            state[layout["belief_grids"]], np.ravel(grids), rtol=1e-5, atol=1e-6
        )
        masses = [infos[a]["posterior_mass"] for a in env.possible_agents]
        np.testing.assert_allclose(state[layout["posterior_masses"]], masses, atol=1e-6)
        if not env.agents:
            break
        _, _, _, _, infos = env.step(_random_actions(env, rng))


def test_state_never_shows_the_true_target() -> None:
    env = infoseek.envs.make("beacon_v0", n_agents=2, **SMALL)
    env.reset(seed=5, options={"target": [30.0, 20.0, 1.0]})
    placed = env.unwrapped.state()
    env.reset(seed=5, options={"target": [3.0, 35.0, 2.0]})
    np.testing.assert_array_equal(placed, env.unwrapped.state())


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_observation_bounds_are_finite_and_hold_a_vehicle_flying_away(env_id: str) -> None:
    env = infoseek.envs.make(env_id, n_agents=2, n_particles=100, max_cycles=40)
    space = env.observation_space("vehicle_0")
    assert np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))
    assert np.all(np.isfinite(env.unwrapped.state_space.low))
    env.reset(seed=0)
    base = env.unwrapped
    layout = base.config.observation_layout
    # the straightest escape: airplanes fly straight (zero turn rate), quadrotors accelerate
    # flat out along -x
    action = np.zeros(1) if env_id == "bearings_v0" else np.array([-1.0, 0.0])
    while env.agents:
        obs, *_ = env.step(dict.fromkeys(env.agents, action))
        raw = base.vehicle_states[0]
        own = obs["vehicle_0"][layout["own_state"]]
        np.testing.assert_allclose(own, raw, rtol=1e-6, atol=1e-4)  # inside: never clipped
        assert space.contains(obs["vehicle_0"])


def test_reassigning_max_cycles_grows_the_position_bounds() -> None:
    env = infoseek.envs.make("bearings_v0", n_agents=1, n_particles=100, max_cycles=10)
    high = env.observation_space("vehicle_0").high[0]
    env.unwrapped.max_cycles = 50
    assert env.observation_space("vehicle_0").high[0] == pytest.approx(high + 40.0)
    with pytest.raises(ValueError, match="max_cycles"):
        env.unwrapped.max_cycles = 0


@pytest.mark.parametrize("gym_id", ["infoseek/Bearings-v0", "infoseek/Beacon-v0"])
def test_single_agent_form_passes_gymnasium_and_sb3_checkers(gym_id: str) -> None:
    env = gymnasium.make(gym_id, n_particles=200, max_cycles=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error", gymnasium.error.Error)  # type: ignore[arg-type]
        gymnasium_check_env(env.unwrapped, skip_render_check=False)
        sb3_check_env(env.unwrapped, warn=False)
    observation, info = env.reset(seed=0)
    assert env.observation_space.contains(observation)
    assert info["entropy"] == pytest.approx(
        math.log(env.unwrapped.parallel.config.space.volume), rel=0.01
    )
    steps = 0
    done = False
    while not done:
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        steps += 1
        done = terminated or truncated
    assert truncated and steps == 5
    env.close()


def test_single_agent_form_rejects_a_team_and_a_step_after_the_end() -> None:
    with pytest.raises(ValueError, match="n_agents must be 1"):
        SingleAgentSearchEnv("bearings_v0", n_agents=2)
    env = SingleAgentSearchEnv("bearings_v0", n_particles=100, max_cycles=1)
    env.reset(seed=0)
    env.step(np.zeros(1, dtype=np.float32))
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        env.step(np.zeros(1, dtype=np.float32))


def test_gymnasium_finds_the_ids_through_the_module_prefix() -> None:
    env = gymnasium.make("infoseek.envs:infoseek/Bearings-v0", n_particles=100)
    assert isinstance(env.unwrapped, SingleAgentSearchEnv)
    env.close()
