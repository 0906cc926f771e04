"""Scripted policies for the information-seeking environments (section III of the paper).

* :class:`SingleNodePlanner` - decentralised, single-node MI approximation (eq. 20);
* :class:`PairwiseNodePlanner` - decentralised, pairwise-node MI approximation (eq. 22, 30);
* :class:`JointPlanner` - centralised exact joint MI (eq. 10), small teams only;
* :class:`RecedingHorizonPlanner` - decentralised, non-myopic: the team's information over
  ``H`` future steps (not in the paper);
* :class:`RandomPolicy`, :class:`LawnmowerPolicy` - baselines.

All share ``Planner.from_env(env, **options)`` and ``planner.act(observations, infos)``; the
coordination of the local programs (eq. 27-30) lives in :mod:`infoseek.planners.coordination`,
the MI estimators in :mod:`infoseek.planners.information` and :mod:`infoseek.planners.utilities`.
"""

from infoseek.planners.base import InformationPlanner, PlanDiagnostics, Planner
from infoseek.planners.config import PlannerConfig
from infoseek.planners.coordination import (
    CoordinationResult,
    PenaltySettings,
    coordinate,
    separation_penalty,
)
from infoseek.planners.joint import JointPlanner
from infoseek.planners.lawnmower import LawnmowerConfig, LawnmowerPolicy
from infoseek.planners.model import EnvModel, Policy
from infoseek.planners.pairwise_node import PairwiseNodePlanner
from infoseek.planners.random_policy import RandomPolicy, RandomPolicyConfig
from infoseek.planners.receding_horizon import RecedingHorizonConfig, RecedingHorizonPlanner
from infoseek.planners.single_node import SingleNodePlanner

__all__ = [
    "CoordinationResult",
    "EnvModel",
    "InformationPlanner",
    "JointPlanner",
    "LawnmowerConfig",
    "LawnmowerPolicy",
    "PairwiseNodePlanner",
    "PenaltySettings",
    "PlanDiagnostics",
    "Planner",
    "PlannerConfig",
    "Policy",
    "RandomPolicy",
    "RandomPolicyConfig",
    "RecedingHorizonConfig",
    "RecedingHorizonPlanner",
    "SingleNodePlanner",
    "coordinate",
    "separation_penalty",
]
