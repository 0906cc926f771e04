"""Tests of the searches of :class:`~infoseek.planners.JointPlanner` (exhaustive and coordinate
ascent) and of its total pair penalty."""

from __future__ import annotations

import numpy as np
import pytest

import infoseek.envs as E
from infoseek.planners import JointPlanner
from infoseek.planners.controls import read_states
from infoseek.planners.coordination import separation_penalty
from infoseek.planners.joint import _pairs_penalty

FAST = {"n_planning": 100, "quadrature_points": 32, "grid_size": 3, "seed": 0}


def test_pairs_penalty_sums_every_pair_once() -> None:
    # on a line: 0 and 1 are 0.5 apart, 1 and 2 are 0.75 apart, 0 and 2 are 1.25 apart
    plan = np.array([[0.0, 0.0], [0.5, 0.0], [1.25, 0.0]])
    assert _pairs_penalty(plan, 1.0, 2.0) == pytest.approx(0.25 + 0.0625)
    assert _pairs_penalty(plan, 1.0, 3.0) == pytest.approx(0.125 + 0.015625)
    batch = np.stack([plan, 10.0 * plan])  # (2, 3, 2): the second plan is feasible
    total = _pairs_penalty(batch, 1.0, 2.0)
    assert total.shape == (2,) and total[1] == 0.0
    by_pairs = sum(
        separation_penalty(plan[a], plan[b][None, :], 1.0) for a, b in ((0, 1), (0, 2), (1, 2))
    )
    assert total[0] == by_pairs


@pytest.fixture(scope="module")
def joint_problem() -> tuple[JointPlanner, object, list[np.ndarray]]:
    """A planner for two agents, its planning belief and the agents' candidate positions."""
    env = E.make("bearings_v0", belief_in_infos=True, n_agents=2, max_cycles=3)
    _, infos = env.reset(seed=2)
    planner = JointPlanner.from_env(env, **FAST)
    agents = list(env.agents)
    belief = planner._beliefs(agents[:1], infos)[0]
    states = read_states(planner.model, infos, agents)
    rows = [planner.model.agent_index(agent) for agent in agents]
    positions = [planner._next_positions(states[r], planner.candidates) for r in rows]
    return planner, belief, positions


def test_exhaustive_search_finds_the_best_feasible_joint_plan(joint_problem) -> None:
    planner, belief, positions = joint_problem
    plans, utility = planner._exhaustive_plans(belief, positions)
    joint = np.stack([positions[a][plans[a]] for a in range(2)])
    assert _pairs_penalty(joint, planner.settings.min_separation, planner.settings.gamma) == 0
    assert utility == pytest.approx(float(belief.joint(joint[None])[0]), rel=1e-12)
    ascent_plans, ascent_utility, _ = planner._coordinate_ascent(belief, positions)
    ascent = np.stack([positions[a][ascent_plans[a]] for a in range(2)])
    assert _pairs_penalty(ascent, planner.settings.min_separation, planner.settings.gamma) == 0
    # the exhaustive optimum bounds the local search (up to the batches' rounding)
    assert utility >= ascent_utility - 1e-12


def test_coordinate_ascent_stops_at_a_coordinate_wise_maximum(joint_problem) -> None:
    planner, belief, positions = joint_problem
    plans, utility, iterations = planner._coordinate_ascent(belief, positions)
    assert 1 <= iterations < planner.settings.max_iterations  # stopped: no plan changed
    for a in range(2):
        choice, value = planner._best_response(belief, positions, plans, a)
        assert choice == plans[a]  # no vehicle improves alone
    assert utility == value  # the joint MI of the last choice
