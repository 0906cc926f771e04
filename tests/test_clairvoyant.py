"""The clairvoyant Fisher reference (infoseek.experiments.clairvoyant)."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.envs import beacon_v0, bearings_v0
from infoseek.experiments.clairvoyant import ClairvoyantFisherReference, fisher_reference
from infoseek.experiments.policies import make_policy


def _env(n_agents: int = 4):
    return bearings_v0.parallel_env(n_agents=n_agents, belief_in_infos=True, max_cycles=30)


def test_fisher_information_is_the_outer_product_of_the_bearing_gradient() -> None:
    reference = ClairvoyantFisherReference(_env())
    rng = np.random.default_rng(0)
    positions = rng.uniform(0.0, 40.0, size=(6, 2))
    target = np.array([21.0, 13.0])
    step = 1e-6
    for position, fisher in zip(positions, reference.fisher(positions, target), strict=True):

        def bearing(t: np.ndarray, p: np.ndarray = position) -> float:
            return float(np.arctan2(t[1] - p[1], t[0] - p[0]))

        gradient = np.array(
            [(bearing(target + e) - bearing(target - e)) / (2 * step) for e in np.eye(2) * step]
        )
        expected = np.outer(gradient, gradient) / 0.1**2  # bearings_v0's sigma
        np.testing.assert_allclose(fisher, expected, rtol=1e-5, atol=1e-9)


def test_reference_gathers_mass_sooner_than_random_flight() -> None:
    masses: dict[str, list[float]] = {"reference": [], "random": []}
    for seed in (1001, 1007, 1011):  # targets far from the start
        for name, mass in masses.items():
            env = _env()
            observations, infos = env.reset(seed=seed)
            policy = fisher_reference(env) if name == "reference" else make_policy("random", env, 0)
            for _ in range(30):
                actions = policy.act(observations, infos)
                for agent, action in actions.items():
                    assert env.action_space(agent).contains(action)
                observations, _, _, _, infos = env.step(actions)
                mass.append(infos[env.possible_agents[0]]["posterior_mass"])
    assert np.mean(masses["reference"]) > np.mean(masses["random"]) + 0.05


def test_reference_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match="lookahead"):
        ClairvoyantFisherReference(_env(), lookahead=0)
    with pytest.raises(TypeError, match="bearing sensors on airplanes"):
        ClairvoyantFisherReference(beacon_v0.parallel_env(n_agents=2))
