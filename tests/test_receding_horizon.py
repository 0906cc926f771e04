"""The receding-horizon planner and its information bound (against brute force and limits)."""

from __future__ import annotations

import numpy as np
import pytest

import infoseek.envs as E
from infoseek.envs.sensors import BearingSensor, make_sensor
from infoseek.planners import RandomPolicy, RecedingHorizonPlanner
from infoseek.planners.horizon_information import HorizonInformation


def _exact_mi_two_bearings(particles, weights, poses, sigma) -> float:
    """I(z1, z2; theta) by quadrature on a fine (z1, z2) grid (wrapped normal noise)."""
    grid = np.linspace(-np.pi, np.pi, 1200, endpoint=False)
    step = grid[1] - grid[0]
    sensor = BearingSensor(sigma)
    dens = [
        np.exp(sensor.log_likelihood(grid[:, None], np.repeat(pose[None], grid.size, 0), particles))
        for pose in poses
    ]  # each (G, N)
    mixture = np.einsum("an,bn,n->ab", dens[0], dens[1], weights)
    h_z = -np.sum(mixture * np.log(np.maximum(mixture, 1e-300))) * step * step
    h_noise = -np.sum(dens[0][:, 0] * np.log(dens[0][:, 0])) * step  # same for every particle
    return h_z - 2.0 * h_noise


@pytest.mark.parametrize("seed", range(3))
def test_bound_lies_below_the_exact_information_and_above_a_third_of_it(seed: int) -> None:
    rng = np.random.default_rng(seed)
    particles = rng.uniform(5.0, 15.0, (6, 2))
    weights = rng.dirichlet(np.ones(6))
    poses = np.array([[0.0, 0.0], [20.0, 3.0]])
    sigma = 0.15
    info = HorizonInformation(BearingSensor(sigma))
    terms = info.pose_terms(particles, poses).sum(axis=0)
    bound = float(info.value(terms, weights))
    exact = _exact_mi_two_bearings(particles, weights, poses, sigma)
    # the Kullback-Leibler version (4x the distance) bounds it from above
    upper = float(info.value(4.0 * terms, weights))
    assert bound <= exact + 1e-6 <= upper + 2e-6, (bound, exact, upper)
    assert bound > 0.3 * exact


def test_bound_is_exact_in_both_limits() -> None:
    info = HorizonInformation(BearingSensor(0.01))
    weights = np.array([0.2, 0.3, 0.5])
    apart = np.array([[10.0, 0.0], [0.0, 10.0], [-10.0, 0.0]])  # bearings 0, pi/2, pi
    value = info.value(info.pose_terms(apart, np.zeros((1, 2))).sum(0), weights)
    assert value == pytest.approx(-np.sum(weights * np.log(weights)), abs=1e-9)
    same = np.array([[10.0, 0.0], [20.0, 0.0], [30.0, 0.0]])  # one bearing for all
    assert info.value(info.pose_terms(same, np.zeros((1, 2))).sum(0), weights) == pytest.approx(
        0.0, abs=1e-9
    )


@pytest.mark.parametrize("sensor", [BearingSensor(0.1), make_sensor("range")])
def test_affinity_table_is_the_gaussian_closed_form(sensor) -> None:
    info = HorizonInformation(sensor)
    delta = np.linspace(-0.3, 0.3, 61) if sensor.name == "bearing" else np.linspace(-2, 2, 41)
    sigma = sensor.sigma
    np.testing.assert_allclose(
        info.log_affinity(delta.copy()), -(delta**2) / (8 * sigma**2), atol=2e-3
    )


def test_planner_needs_an_additive_noise_sensor_and_valid_options() -> None:
    with pytest.raises(TypeError, match="additive-noise sensor"):
        RecedingHorizonPlanner.from_env(E.make("beacon_v0", belief_in_infos=True))
    env = E.make("bearings_v0", belief_in_infos=True)
    for bad in ({"horizon": 0}, {"hold_grid_size": 1}, {"horizon": 2.5}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            RecedingHorizonPlanner.from_env(env, **bad)


def _episode_mass(policy_factory, seed: int, steps: int = 15) -> float:
    env = E.make("bearings_v0", n_agents=2, n_particles=500, max_cycles=steps, belief_in_infos=True)
    observations, infos = env.reset(seed=seed)
    policy = policy_factory(env)
    masses = []
    while env.agents:
        actions = policy.act(observations, infos)
        for agent, action in actions.items():
            assert env.action_space(agent).contains(action)
        observations, _, _, _, infos = env.step(actions)
        masses.append(infos[env.possible_agents[0]]["posterior_mass"])
        assert all(info["separation_violations"] == 0 for info in infos.values())
    return float(np.mean(masses))


def test_closed_loop_beats_random_flight_and_is_seeded() -> None:
    def horizon(env):
        return RecedingHorizonPlanner.from_env(env, seed=3, n_planning=64, horizon=4)

    def random(env):
        return RandomPolicy.from_env(env, seed=3)

    planned = [_episode_mass(horizon, seed) for seed in range(3)]
    flown = [_episode_mass(random, seed) for seed in range(3)]
    assert np.mean(planned) > np.mean(flown) + 0.05, (planned, flown)
    assert _episode_mass(horizon, 0) == planned[0]


def _numpy_terms(info: HorizonInformation, particles, poses) -> np.ndarray:
    """``(P, N, N)`` pair terms at ``(P, 2)`` poses: the NumPy code before the kernels."""
    predictions = np.asarray(info.sensor.predict(poses, particles), dtype=np.float64)[..., 0]
    delta = predictions[:, :, None] - predictions[:, None, :]
    delta = np.mod(delta + 0.5 * info.period, info.period) - 0.5 * info.period
    position = (delta - info._delta0) / info._step
    np.clip(position, 0.0, info._table.size - 1 - 1e-9, out=position)
    index = position.astype(np.intp)
    position -= index
    low = info._table[index]
    return low + position * (info._table[index + 1] - low)


def _numpy_value(log_rho: np.ndarray, weights: np.ndarray) -> np.ndarray:
    shifted = log_rho + np.log(weights)[None, :]
    top = shifted.max(axis=-1, keepdims=True)
    return -((np.log(np.exp(shifted - top).sum(axis=-1)) + top[..., 0]) @ weights)


def test_sequence_utilities_are_the_bound_of_the_summed_pose_terms(rng) -> None:
    """The planner's cached utility against the NumPy form of the planner before the kernels,
    bit for bit, and unchanged by a caller's edit of a returned array."""
    from infoseek.planners.receding_horizon import _SequenceUtilities
    from infoseek.planners.utilities import PlanningBelief

    info = HorizonInformation(BearingSensor(0.1))
    n, n_seq, horizon = 20, 6, 3
    beliefs = [
        PlanningBelief(rng.uniform(5.0, 35.0, (n, 2)), np.full(n, 1.0 / n)) for _ in range(3)
    ]
    tracks = rng.uniform(0.0, 40.0, (3, n_seq, horizon, 2))
    tracks[:, 1, 0] = tracks[:, 0, 0]  # sequences sharing their first pose
    utility = _SequenceUtilities(info, beliefs, tracks)
    plans = np.array([4, 1, 2])
    for i, belief in enumerate(beliefs):
        terms = _numpy_terms(info, belief.particles, tracks[i].reshape(-1, 2))
        total = terms.reshape(n_seq, horizon, n, n).sum(axis=1)
        alone = _numpy_value(total, belief.weights)
        for j in range(3):
            if j != i:
                total = total + _numpy_terms(info, belief.particles, tracks[j, plans[j]]).sum(0)
        expected = _numpy_value(total, belief.weights)
        assert utility.alone(i).tobytes() == alone.tobytes()
        first = utility(i, plans)
        assert first.tobytes() == expected.tobytes()
        first[:] = 0.0  # the caller's copy: the cache keeps its own
        assert utility(i, plans).tobytes() == expected.tobytes()
