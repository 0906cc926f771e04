"""Tests of infoseek.planners.utilities: single-node, pairwise-node and joint utilities."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.envs.sensors import BearingSensor, RangeSensor
from infoseek.planners.information import mutual_information
from infoseek.planners.utilities import (
    PlanningBelief,
    joint_utilities,
    joint_utility,
    pairwise_node_utilities,
    pairwise_node_utility,
    single_node_utilities,
    single_node_utility,
    subsample_particles,
)


def _belief(rng: np.random.Generator, n: int = 300) -> PlanningBelief:
    centres = np.array([[12.0, 25.0], [26.0, 14.0], [30.0, 30.0]])
    xy = centres[rng.integers(0, 3, n)] + rng.normal(0.0, 3.0, (n, 2))
    weights = rng.gamma(0.8, size=n)
    return PlanningBelief(np.clip(xy, 0.0, 40.0), weights / weights.sum())


def test_single_node_utility_is_own_mi():
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(0)
    belief = _belief(rng)
    poses = rng.uniform(0.0, 40.0, (4, 2))
    for i in range(4):
        expected = mutual_information(sensor, poses[i : i + 1], belief.particles, belief.weights)
        assert single_node_utility(belief, sensor, poses, i) == pytest.approx(expected, abs=1e-12)
    batched = single_node_utilities(belief, sensor, poses)
    assert batched == pytest.approx(
        [single_node_utility(belief, sensor, poses, i) for i in range(4)]
    )


@pytest.mark.parametrize("sensor", [BearingSensor(0.1), RangeSensor(0.5)], ids=["bearing", "range"])
def test_pairwise_equals_joint_for_two_vehicles(sensor):
    rng = np.random.default_rng(1)
    belief = _belief(rng)
    poses = rng.uniform(0.0, 40.0, (2, 2))
    joint = joint_utility(belief, sensor, poses)
    for i in range(2):
        assert pairwise_node_utility(belief, sensor, poses, i) == pytest.approx(joint, abs=1e-5)
    # and it is genuinely more than either single-node utility
    assert joint > max(single_node_utility(belief, sensor, poses, i) for i in range(2))


def test_pairwise_needs_two_vehicles():
    sensor = BearingSensor()
    belief = _belief(np.random.default_rng(2))
    with pytest.raises(ValueError, match="n_v >= 2"):
        pairwise_node_utility(belief, sensor, np.array([[1.0, 1.0]]), 0)
    with pytest.raises(ValueError, match="n_v >= 2"):
        pairwise_node_utilities(belief, sensor, np.array([[1.0, 1.0]]), np.zeros((0, 2)))
    with pytest.raises(ValueError, match="agent_index"):
        single_node_utility(belief, sensor, np.array([[1.0, 1.0]]), 1)
    with pytest.raises(TypeError, match="particles"):
        single_node_utility(object(), sensor, np.array([[1.0, 1.0]]), 0)


@pytest.mark.parametrize("method", ["fft", "quadrature"])
def test_batched_pairwise_matches_formula(method):
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(3)
    belief = _belief(rng, 200)
    candidates = rng.uniform(0.0, 40.0, (5, 2))
    others = rng.uniform(0.0, 40.0, (3, 2))
    batched = pairwise_node_utilities(belief, sensor, candidates, others, method=method)
    p, w = belief.particles, belief.weights
    for c, candidate in enumerate(candidates):
        single = mutual_information(sensor, candidate[None], p, w, method=method)
        pairs = [
            mutual_information(sensor, np.stack([candidate, o]), p, w, method=method)
            for o in others
        ]
        expected = (2 - 4) * single + sum(pairs)  # eq. 22 with n_v = 4
        assert batched[c] == pytest.approx(expected, abs=1e-6)
        poses = np.vstack([others[:1], candidate[None], others[1:]])
        assert pairwise_node_utility(belief, sensor, poses, 1, method=method) == pytest.approx(
            batched[c], abs=1e-9
        )
    joint = joint_utilities(belief, sensor, candidates, others[:2], method=method)
    for c, candidate in enumerate(candidates):
        poses = np.vstack([candidate[None], others[:2]])
        assert joint[c] == pytest.approx(joint_utility(belief, sensor, poses, 0, method=method))


def test_proposition_3_pairwise_error_never_exceeds_single_node_error():
    """|I - sum_j I(z_j)| >= |I - V_p| for every vehicle, over random 3-vehicle configurations.

    The grid MI is the exact MI of a discretised channel with conditionally independent
    observations, so the information identities behind Propositions 1-3 hold for it exactly:
    for n_v = 3, I - V_p = -I(z_j; z_k | z_i) <= 0 and I - sum_j I(z_j) = -I(z_1; z_2) -
    I(z_3; z_1, z_2) <= I - V_p.
    """
    sensor = BearingSensor(0.3)
    rng = np.random.default_rng(4)
    options = {"method": "quadrature", "n_points": 40}
    gaps = []
    for _ in range(25):
        belief = _belief(rng, 150)
        poses = rng.uniform(0.0, 40.0, (3, 2))
        joint = joint_utility(belief, sensor, poses, **options)
        singles = [single_node_utility(belief, sensor, poses, i, **options) for i in range(3)]
        single_error = joint - sum(singles)
        for i in range(3):
            pairwise_error = joint - pairwise_node_utility(belief, sensor, poses, i, **options)
            assert abs(single_error) >= abs(pairwise_error) - 1e-9
            assert pairwise_error <= 1e-9 and single_error <= 1e-9
            gaps.append(abs(single_error) - abs(pairwise_error))
    assert max(gaps) > 0.05  # correlated observations: the pairwise form is strictly better


def test_proposition_3_with_the_fft_path():
    sensor = BearingSensor(0.1)
    rng = np.random.default_rng(5)
    for _ in range(3):
        belief = _belief(rng, 300)
        poses = rng.uniform(0.0, 40.0, (3, 2))
        joint = joint_utility(belief, sensor, poses)  # 3-D histogram + 3-D FFT
        singles = sum(single_node_utility(belief, sensor, poses, i) for i in range(3))
        for i in range(3):
            pairwise = pairwise_node_utility(belief, sensor, poses, i)
            assert abs(joint - singles) >= abs(joint - pairwise) - 2e-3


def test_subsample_particles():
    rng = np.random.default_rng(6)
    particles = rng.normal(0.0, 1.0, (5000, 2))
    weights = np.exp(particles[:, 0])  # tilted: weighted mean of x is 1
    weights /= weights.sum()
    belief = PlanningBelief(particles, weights)
    small = subsample_particles(belief, 1000, np.random.default_rng(7))
    assert small.particles.shape == (1000, 2)
    assert np.allclose(small.weights, 1e-3)
    assert abs(small.particles[:, 0].mean() - weights @ particles[:, 0]) < 0.08
    again = subsample_particles(belief, 1000, np.random.default_rng(7))
    assert np.array_equal(small.particles, again.particles)
    whole = subsample_particles(belief, 10_000, np.random.default_rng(7))
    assert np.array_equal(whole.particles, particles) and np.allclose(whole.weights, weights)
    with pytest.raises(ValueError, match="n_planning"):
        subsample_particles(belief, 0, np.random.default_rng(7))
    with pytest.raises(TypeError, match="rng"):
        subsample_particles(belief, 10, 7)
