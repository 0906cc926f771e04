r"""Centralised planner with the exact joint mutual information (eq. 10) - the reference.

The team's next controls maximise :math:`I(z^{(1)}_{t+1}, \dots, z^{(n_v)}_{t+1}; \theta)`,
computed exactly (to quadrature accuracy) from one belief - the first active agent's own belief
(a centralised planner has a single belief; with full communication every agent's belief is
nearly the same). The separation constraint is enforced exactly, not by a penalty: joint plans
that keep every pair at least ``min_separation + separation_margin`` apart are preferred; if no
joint candidate is feasible, the one with the smallest total penalty (eq. 27) is taken.

Search: exhaustive over all ``C^{n_v}`` joint candidates when that number is at most
``max_exhaustive`` (81 by default: 9 turn rates for 2 airplanes); otherwise coordinate
ascent (vehicles in turn pick their best candidate with the others fixed, from the
single-node choices, until no plan changes or ``max_iterations`` sweeps).

Limit: the joint MI of ``n_v`` observations is evaluated on an ``n_v``-dimensional observation
grid, which the MI module supports for ``n_v <= 3``; the planner refuses larger teams
(``max_joint_agents``, default 3) with a ``ValueError`` rather than silently switching to a Monte
Carlo estimate. Grid controls only (no continuous refinement).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.base import InformationPlanner, PlanDiagnostics
from infoseek.planners.config import PlannerConfig
from infoseek.planners.controls import controls_to_actions
from infoseek.planners.coordination import max_violation, separation_penalty
from infoseek.planners.information import MAX_GRID_OBSERVATIONS, BeliefMI
from infoseek.planners.model import EnvModel, FloatArray

__all__ = ["JointPlanner"]


class JointPlanner(InformationPlanner):
    """Centralised exact-joint-MI planner for small teams (``n_v <= max_joint_agents``)."""

    def __init__(self, model: EnvModel, config: PlannerConfig) -> None:
        limit = min(config.max_joint_agents, MAX_GRID_OBSERVATIONS)
        if model.n_agents > limit:
            raise ValueError(
                f"JointPlanner: n_agents={model.n_agents} exceeds the limit of {limit} vehicles "
                f"(exact joint MI on an n_v-dimensional observation grid; max_joint_agents="
                f"{config.max_joint_agents}, MI grid limit {MAX_GRID_OBSERVATIONS}); use "
                "PairwiseNodePlanner for larger teams"
            )
        super().__init__(model, config)

    def _observations_needed(self, model: EnvModel) -> int:
        return model.n_agents

    def _plan(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        start = time.perf_counter()
        self._utility_seconds = 0.0
        rows = [self.model.agent_index(agent) for agent in agents]
        belief = self._beliefs(agents[:1], infos)[0]
        positions = [self._next_positions(states[r], self.candidates) for r in rows]
        iterations = 1
        if self.candidates.shape[0] ** len(agents) <= self.config.max_exhaustive:
            plans, utility = self._exhaustive_plans(belief, positions)
        else:
            plans, utility, iterations = self._coordinate_ascent(belief, positions)
        controls = self.candidates[plans]
        final_positions = np.array([positions[a][plans[a]] for a in range(len(agents))])
        actions = controls_to_actions(self.model, agents, controls)
        self.last_plan = dataclasses.replace(
            PlanDiagnostics(
                agents=tuple(agents),
                controls=controls,
                grid_controls=controls,
                utilities=np.full(len(agents), utility),
                iterations=iterations,
                converged=True,
                max_violation=max_violation(final_positions, self.settings.min_separation),
                agreement_residual=0.0,
                beta=self.settings.beta,
                refined=False,
                planning_time=0.0,
                utility_time=0.0,
            ),
            planning_time=time.perf_counter() - start,
            utility_time=self._utility_seconds,
        )
        return actions

    def _exhaustive_plans(
        self, belief: BeliefMI, positions: list[FloatArray]
    ) -> tuple[NDArray[np.int64], float]:
        """The best of all ``C^n`` joint candidates and its joint MI: the largest MI among the
        feasible ones, or the smallest total penalty if none is feasible.

        Args:
            belief: The planning belief.
            positions: Per vehicle, ``(C, 2)`` next positions of the candidates.
        """
        n = len(positions)
        combos = np.array(
            list(itertools.product(range(self.candidates.shape[0]), repeat=n)), dtype=np.int64
        )
        joint = np.stack([positions[a][combos[:, a]] for a in range(n)], axis=1)  # (K, n, 2)
        penalties = _pairs_penalty(joint, self.settings.min_separation, self.settings.gamma)
        values = self._timed(belief.joint, joint)
        score = np.where(penalties > 0, -np.inf, values)
        best = int(np.argmax(score)) if np.isfinite(score).any() else int(np.argmin(penalties))
        return combos[best].copy(), float(values[best])

    def _coordinate_ascent(
        self, belief: BeliefMI, positions: list[FloatArray]
    ) -> tuple[NDArray[np.int64], float, int]:
        """Sweeps of best responses from the single-node choices until no plan changes or
        ``max_iterations`` sweeps; the plans, the joint MI of the last choice and the sweeps.

        Args:
            belief: The planning belief.
            positions: Per vehicle, ``(C, 2)`` next positions of the candidates.
        """
        plans = np.array([int(np.argmax(self._single(belief, track))) for track in positions])
        utility = -np.inf
        iterations = 1
        for sweep in range(1, self.settings.max_iterations + 1):
            iterations = sweep
            changed = False
            for a in range(len(positions)):
                choice, utility = self._best_response(belief, positions, plans, a)
                changed |= choice != plans[a]
                plans[a] = choice
            if not changed:
                break
        return plans, utility, iterations

    def _best_response(
        self, belief: BeliefMI, positions: list[FloatArray], plans: NDArray[np.int64], a: int
    ) -> tuple[int, float]:
        """Vehicle ``a``'s best candidate with the others' ``plans`` fixed (its current plan on
        ties; the smallest penalty if none is feasible) and the joint MI of that choice.

        Args:
            belief: The planning belief.
            positions: Per vehicle, ``(C, 2)`` next positions of the candidates.
            plans: ``(n,)`` current candidate index of every vehicle.
            a: The vehicle that chooses.
        """
        others = np.array([positions[b][plans[b]] for b in range(len(positions)) if b != a])
        sets = np.concatenate(
            [
                positions[a][:, None, :],
                np.broadcast_to(others, (self.candidates.shape[0],) + others.shape),
            ],
            axis=1,
        )
        values = self._timed(belief.joint, sets)
        penalties = separation_penalty(
            positions[a], others, self.settings.min_separation, self.settings.gamma
        )
        score = np.where(penalties > 0, -np.inf, values)
        if np.isfinite(score).any():
            choice = int(np.argmax(score))
            if score[plans[a]] >= score[choice]:
                choice = int(plans[a])
        else:
            choice = int(np.argmin(penalties))
        return choice, float(values[choice])


def _pairs_penalty(joint_positions: FloatArray, min_separation: float, gamma: float) -> FloatArray:
    """Total separation penalty (eq. 27) over every pair of vehicles of joint plans.

    Args:
        joint_positions: ``(..., n, 2)`` next positions of the ``n`` vehicles of each plan.
        min_separation: The separation.
        gamma: Penalty exponent.

    Returns:
        ``(...)`` sum over pairs ``a < b`` of the penalty of ``a`` against ``b``.
    """
    n = joint_positions.shape[-2]
    total = np.zeros(joint_positions.shape[:-2])
    for a in range(n):
        for b in range(a + 1, n):
            total = total + separation_penalty(
                joint_positions[..., a, :],
                joint_positions[..., b, :][..., None, :],
                min_separation,
                gamma,
            )
    return total
