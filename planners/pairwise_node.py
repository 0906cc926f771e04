r"""Pairwise-node approximation planner (Proposition 2, eq. 22, slack copies of eq. 30).

Vehicle :math:`i` maximises, on its own belief,

.. math::

    V_p^{(i)} = (2 - n_v)\, I(z^{(i)}; \theta) + \sum_{j \ne i} I(z^{(i)}, z^{(j)}; \theta),

where :math:`z^{(j)}` is the observation vehicle :math:`j` would make at the next position of
its plan *as held in vehicle i's slack copy* :math:`\tilde u^{(i)}` (eq. 30). The copies are
exact copies of the latest exchanged plans (best response, a deviation from eq. 30's penalised
agreement; :mod:`~infoseek.planners.coordination` says what that drops and why it is sound:
coordinate ascent on a team potential); the final copies agree with the final plans at
convergence (``last_plan.agreement_residual``).

Cost control: the single terms are computed once per step (one batched call per vehicle). The
pair terms :math:`I(z^{(i)}_c, z^{(j)}; \theta)` for all of vehicle ``i``'s candidates ``c`` are
a column per partner plan; columns are cached by ``(i, j, plan of j)`` and only the columns
of partners whose plan changed are computed, in one batched
:meth:`~infoseek.planners.information.BeliefMI.pairs` call per vehicle and iteration (one
:class:`~infoseek.planners.information.BeliefMI` per vehicle and step: the per-pose work of the
candidates and partner plans is cached across sweeps and the refinement). The single and pair
terms come from the same estimator grid, so eq. 22 combines values of one resolution. The initial
exchange is every vehicle's single-node argmax.

Needs ``n_v >= 2``: building it for a one-vehicle environment raises ``ValueError``.
"""

from __future__ import annotations

import numpy as np

from infoseek.planners.base import FloatArray, InformationPlanner
from infoseek.planners.coordination import IntArray, UtilityFunction
from infoseek.planners.information import BeliefMI

__all__ = ["PairwiseNodePlanner"]


class PairwiseNodePlanner(InformationPlanner):
    """Decentralised planner with the pairwise-node utility (eq. 22).

    Build with ``PairwiseNodePlanner.from_env(env, **options)``; options are the fields of
    :class:`~infoseek.planners.config.PlannerConfig`.
    """

    min_agents = 2
    observations_per_term = 2

    def _utility_function(
        self,
        beliefs: list[BeliefMI],
        positions: list[FloatArray],
        singles: list[FloatArray],
    ) -> UtilityFunction:
        n_vehicles = len(positions)
        columns: list[dict[tuple[int, int], FloatArray]] = [{} for _ in range(n_vehicles)]

        def utility(i: int, plans: IntArray) -> FloatArray:
            cache = columns[i]
            partners = [j for j in range(n_vehicles) if j != i]
            missing = [j for j in partners if (j, int(plans[j])) not in cache]
            if missing:
                others = np.array([positions[j][plans[j]] for j in missing])
                pairs = self._pairs(beliefs[i], positions[i], others)  # (C, len(missing))
                for column, j in enumerate(missing):
                    cache[(j, int(plans[j]))] = pairs[:, column]
            total = (2 - n_vehicles) * singles[i]
            for j in partners:
                total = total + cache[(j, int(plans[j]))]
            return total

        return utility
