"""The batched vector env (``infoseek.baselines.make_vec``): parity with the PettingZoo env, SB3
conventions, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.baselines import make_vec
from infoseek.envs import make

TINY = {"n_particles": 300, "max_cycles": 6}


def _random_actions(venv, rng: np.random.Generator, steps: int) -> np.ndarray:
    space = venv.action_space
    if hasattr(space, "n"):
        return rng.integers(0, space.n, size=(steps, venv.num_envs))
    return rng.uniform(space.low, space.high, size=(steps, venv.num_envs, *space.shape))


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("bearings_v0", {"n_agents": 3}),
        ("beacon_v0", {"n_agents": 2, "action_type": "discrete"}),
        ("bearings_v0", {"n_agents": 2, "message_loss": 0.3, "terminate_on_localization": True}),
    ],
)
def test_vector_env_follows_the_pettingzoo_env_bit_for_bit(env_id: str, kwargs: dict) -> None:
    """Environment b of the batch == the PettingZoo env reset with seed + b, across episodes
    (the auto-reset continues each environment's seed sequence, as reset(seed=None) does)."""
    config = {**TINY, **kwargs}
    n_envs, steps, seed = 3, 2 * TINY["max_cycles"] + 1, 40
    venv = make_vec(env_id, num_envs=n_envs, **config)
    venv.seed(seed)
    observations = [venv.reset()]
    actions = _random_actions(venv, np.random.default_rng(1), steps)
    rewards, dones, infos = [], [], []
    for t in range(steps):
        obs, rew, done, info = venv.step(actions[t])
        observations.append(obs)
        rewards.append(rew)
        dones.append(done)
        infos.append(info)
    a = config["n_agents"]
    for b in range(n_envs):
        env = make(env_id, **config)
        obs, _ = env.reset(seed=seed + b)
        slots = range(b * a, (b + 1) * a)
        for t in range(steps):
            assert all(
                np.array_equal(obs[agent], observations[t][k])
                for agent, k in zip(env.possible_agents, slots, strict=True)
            ), f"env {b} step {t}: observations differ"
            obs, rew, term, trunc, _ = env.step(
                {agent: actions[t][k] for agent, k in zip(env.possible_agents, slots, strict=True)}
            )
            for agent, k in zip(env.possible_agents, slots, strict=True):
                assert np.float32(rew[agent]) == rewards[t][k]
                assert dones[t][k] == (term[agent] or trunc[agent])
                if dones[t][k]:
                    assert np.array_equal(infos[t][k]["terminal_observation"], obs[agent])
                    assert infos[t][k]["TimeLimit.truncated"] == trunc[agent]
            if not env.agents:
                obs, _ = env.reset()


def test_beliefs_of_the_batch_equal_those_of_the_pettingzoo_env() -> None:
    venv = make_vec("bearings_v0", num_envs=2, n_agents=2, **TINY)
    venv.seed(7)
    venv.reset()
    actions = _random_actions(venv, np.random.default_rng(2), 4)
    for step in actions:
        venv.step(step)
    env = make("bearings_v0", n_agents=2, **TINY)
    env.reset(seed=8)
    for step in actions:
        env.step({agent: step[2 + i] for i, agent in enumerate(env.possible_agents)})
    for i, agent in enumerate(env.possible_agents):
        belief = env.belief(agent)
        np.testing.assert_array_equal(venv.core.beliefs.particles[2 + i], belief.particles)
        np.testing.assert_array_equal(venv.core.beliefs.log_weights[2 + i], belief.log_weights)


def test_episode_records_and_truncation_flags_follow_sb3() -> None:
    venv = make_vec("bearings_v0", num_envs=2, n_agents=2, **TINY)
    venv.seed(0)
    venv.reset()
    returns = np.zeros(venv.num_envs)
    zeros = np.zeros((venv.num_envs, 1), np.float32)
    for step in range(TINY["max_cycles"]):
        _, rewards, dones, infos = venv.step(zeros)
        returns += rewards
        last = step == TINY["max_cycles"] - 1
        assert np.all(dones == last)
        for k, info in enumerate(infos):
            assert info["TimeLimit.truncated"] == last
            assert ("episode" in info) == last
            if last:
                assert info["episode"]["l"] == TINY["max_cycles"]
                assert info["episode"]["r"] == pytest.approx(returns[k], rel=1e-5, abs=1e-6)
    assert venv.get_attr("n_agents") == [2] * venv.num_envs
    assert venv.env_is_wrapped(object) == [False] * venv.num_envs


def test_ppo_learns_on_the_vector_env() -> None:
    from stable_baselines3 import PPO

    venv = make_vec("bearings_v0", num_envs=2, n_agents=2, **TINY)
    model = PPO("MlpPolicy", venv, n_steps=8, batch_size=16, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=64)
    assert model.num_timesteps >= 64


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: make_vec("bearings_v0", num_envs=0), "num_envs must be an integer >= 1"),
        (lambda: make_vec("bearings_v0", num_envs=2.5), "num_envs must be an integer >= 1"),
        (lambda: make_vec("nope_v0", num_envs=2), "unknown environment id 'nope_v0'"),
        (lambda: make_vec("bearings_v0", num_envs=2, n_agent=3), "unknown configuration key"),
    ],
)
def test_bad_arguments_name_themselves(call, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        call()


def test_actions_of_the_wrong_shape_name_the_expected_shape() -> None:
    venv = make_vec("bearings_v0", num_envs=2, n_agents=3, **TINY)
    venv.reset()
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 3, 1\) or \(6, 1\)"):
        venv.step(np.zeros((5, 1)))
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.full((6, 1), np.nan))
    discrete = make_vec("bearings_v0", num_envs=2, n_agents=3, action_type="discrete", **TINY)
    discrete.reset()
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 3\) or \(6,\)"):
        discrete.step(np.zeros((6, 1), dtype=np.int64))
    with pytest.raises(ValueError, match=r"must be in \[0, 5\)"):
        discrete.step(np.full(6, 5))


def test_worker_processes_give_the_same_numbers_as_one_process() -> None:
    config = {**TINY, "n_agents": 2}
    actions = _random_actions(
        make_vec("bearings_v0", num_envs=3, **config), np.random.default_rng(5), 8
    )
    runs = []
    for workers in (1, 2):
        venv = make_vec("bearings_v0", num_envs=3, n_workers=workers, **config)
        try:
            venv.seed(11)
            run = [venv.reset()]
            for step in actions:
                obs, rewards, dones, infos = venv.step(step)
                run += [obs, rewards, dones, [sorted(info) for info in infos]]
            runs.append(run)
        finally:
            venv.close()
    for one, two in zip(*runs, strict=True):
        if isinstance(one, np.ndarray):
            np.testing.assert_array_equal(one, two)
        else:
            assert one == two


def test_a_bad_worker_count_names_itself() -> None:
    with pytest.raises(ValueError, match=r"n_workers must be an integer in \[1, num_envs=2\]"):
        make_vec("bearings_v0", num_envs=2, n_workers=3)
