"""The optional ``belief_moments`` observation block against the agent's own particles."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.baselines import make_vec
from infoseek.envs import make


def _brute_force_moments(belief, radius: float) -> np.ndarray:
    """``(s_x, s_y, rho, mass)`` from the particles by plain weighted sums."""
    weights = belief.weights / belief.weights.sum()
    positions = belief.particles[:, :2]
    mean = belief.mmse()
    dx = positions[:, 0] - mean[0]
    dy = positions[:, 1] - mean[1]
    sx = np.sqrt(np.sum(weights * dx * dx))
    sy = np.sqrt(np.sum(weights * dy * dy))
    rho = np.sum(weights * dx * dy) / (sx * sy)
    mass = np.sum(weights[dx * dx + dy * dy <= radius * radius])
    return np.array([sx, sy, rho, min(mass, 1.0)])


@pytest.mark.parametrize("env_id", ["bearings_v0", "beacon_v0"])
def test_moments_block_equals_the_particles_spread(env_id: str) -> None:
    env = make(env_id, n_agents=3, n_particles=500, belief_moments=True)
    config = env.unwrapped.config
    block = config.observation_layout["belief_moments"]
    observations, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(12):
        space = env.action_space(env.agents[0])
        actions = {a: rng.uniform(space.low, space.high).astype(np.float32) for a in env.agents}
        observations, *_ = env.step(actions)
    for agent in env.possible_agents:
        expected = _brute_force_moments(
            env.unwrapped.agent_belief(agent), config.localization_radius
        )
        np.testing.assert_allclose(observations[agent][block], expected, rtol=1e-5, atol=1e-6)
        assert env.observation_space(agent).contains(observations[agent])


def test_moments_are_off_by_default_and_change_nothing_else() -> None:
    plain = make("bearings_v0", n_agents=2, n_particles=300)
    extended = make("bearings_v0", n_agents=2, n_particles=300, belief_moments=True)
    assert "belief_moments" not in plain.unwrapped.config.observation_layout
    a, _ = plain.reset(seed=5)
    b, _ = extended.reset(seed=5)
    for _ in range(5):
        actions = {agent: np.array([0.3], dtype=np.float32) for agent in plain.agents}
        a, *_ = plain.step(actions)
        b, *_ = extended.step(actions)
    for agent in plain.possible_agents:
        np.testing.assert_array_equal(b[agent][: a[agent].size], a[agent])
        assert b[agent].size == a[agent].size + 4


def test_moments_reach_the_batched_vec_env() -> None:
    venv = make_vec("bearings_v0", num_envs=2, n_agents=2, n_particles=300, belief_moments=True)
    observations = venv.reset()
    assert observations.shape == (4, 3 + 2 + 64 + 2 + 4)
    venv.close()


def test_belief_moments_must_be_a_bool() -> None:
    with pytest.raises(TypeError, match="belief_moments"):
        make("bearings_v0", belief_moments="yes")
