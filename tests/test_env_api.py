"""PettingZoo conformance of every registered environment (parallel API, seeding, AEC API)."""

from __future__ import annotations

import functools
import warnings

import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

import infoseek.envs
from infoseek.envs.registration import registry

N_CYCLES = 4
CONFIGS = [
    (env_id, n_agents, action_type)
    for env_id in sorted(registry)
    for n_agents in (1, 2, 4, 10)
    for action_type in ("continuous", "discrete")
]


def _kwargs(n_agents: int, action_type: str) -> dict:
    return {
        "n_agents": n_agents,
        "action_type": action_type,
        "n_particles": 200,
        "max_cycles": N_CYCLES,
        "n_discrete_actions": 3,
    }


@pytest.fixture(autouse=True)
def _quiet_pettingzoo_advice():
    # PettingZoo's checkers warn about unbounded (relative-position) observation bounds and
    # similar style advice; those are documented design choices, not failures.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        yield


def test_both_paper_environments_are_registered() -> None:
    assert {"bearings_v0", "beacon_v0"} <= set(registry)


@pytest.mark.parametrize(("env_id", "n_agents", "action_type"), CONFIGS)
def test_parallel_api(env_id: str, n_agents: int, action_type: str) -> None:
    env = infoseek.envs.make(env_id, **_kwargs(n_agents, action_type))
    parallel_api_test(env, num_cycles=N_CYCLES + 2)
    assert env.agents == []  # the episode ran to truncation inside the checker


@pytest.mark.parametrize(("env_id", "n_agents", "action_type"), CONFIGS)
def test_parallel_seed(env_id: str, n_agents: int, action_type: str) -> None:
    parallel_seed_test(
        functools.partial(infoseek.envs.make, env_id, **_kwargs(n_agents, action_type)),
        num_cycles=N_CYCLES,
    )


@pytest.mark.parametrize(("env_id", "n_agents", "action_type"), CONFIGS)
def test_aec_api(env_id: str, n_agents: int, action_type: str) -> None:
    aec = infoseek.envs.make(env_id, parallel=False, **_kwargs(n_agents, action_type))
    api_test(aec, num_cycles=N_CYCLES + 2)


@pytest.mark.parametrize("env_id", sorted(registry))
def test_module_entry_points_agree_with_make(env_id: str) -> None:
    module = getattr(infoseek.envs, env_id)
    kwargs = _kwargs(2, "continuous")
    par = module.parallel_env(**kwargs)
    aec = module.env(**kwargs)
    raw = module.raw_env(**kwargs)
    assert par.metadata["name"] == env_id
    assert aec.unwrapped.metadata["name"] == env_id
    assert raw.unwrapped.observation_space("vehicle_0") == par.observation_space("vehicle_0")
    made = infoseek.envs.make(env_id, **kwargs)
    assert type(made) is type(par)
    assert made.observation_space("vehicle_1") == par.observation_space("vehicle_1")


@pytest.mark.parametrize("env_id", sorted(registry))
@pytest.mark.parametrize("action_type", ["continuous", "discrete"])
def test_space_dicts_cover_every_possible_agent(env_id: str, action_type: str) -> None:
    """``observation_spaces`` / ``action_spaces`` (PettingZoo's dict attributes) exist and
    agree with the per-agent methods, for every possible agent."""
    env = infoseek.envs.make(env_id, **_kwargs(3, action_type))
    assert set(env.observation_spaces) == set(env.possible_agents) == set(env.action_spaces)
    for agent in env.possible_agents:
        assert env.observation_spaces[agent] == env.observation_space(agent)
        assert env.action_spaces[agent] == env.action_space(agent)
    env.observation_spaces.clear()  # a copy: the env's own spaces are untouched
    assert env.observation_space("vehicle_0") is not None
