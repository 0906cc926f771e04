r"""Single-node approximation planner (Proposition 1, eq. 20, with the local program eq. 29).

Vehicle :math:`i` maximises :math:`V_s^{(i)} = I(z^{(i)}_{t+1}; \theta^{(i)}_t)` computed on its
*own* belief: the mutual information between the target and its own next observation only.
The utility does not depend on the other vehicles' plans, so each step evaluates it once per
vehicle, in one batched call over all candidate controls; the coordination iterations only
re-evaluate the separation penalty (eq. 27-28). Cooperation comes from the shared observations
(all beliefs condition on everyone's measurements) and from the separation coupling.
"""

from __future__ import annotations

from infoseek.planners.base import FloatArray, InformationPlanner
from infoseek.planners.coordination import UtilityFunction
from infoseek.planners.information import BeliefMI

__all__ = ["SingleNodePlanner"]


class SingleNodePlanner(InformationPlanner):
    """Decentralised planner with the single-node utility (eq. 20).

    Build with ``SingleNodePlanner.from_env(env, **options)``; options are the fields of
    :class:`~infoseek.planners.config.PlannerConfig`.
    """

    def _utility_function(
        self,
        beliefs: list[BeliefMI],
        positions: list[FloatArray],
        singles: list[FloatArray],
    ) -> UtilityFunction:
        def utility(i: int, plans: object) -> FloatArray:
            return singles[i]

        return utility
