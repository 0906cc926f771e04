"""The planners by the short names the command line and the trainers use.

``PLANNER_CLASSES[name]`` is the class name in :mod:`infoseek.planners`; a new planner is one
entry here (and its class exported by the package).
"""

from __future__ import annotations

__all__ = ["INFORMATION_PLANNERS", "PLANNER_CLASSES"]

#: Short name -> class name in :mod:`infoseek.planners`.
PLANNER_CLASSES: dict[str, str] = {
    "pairwise": "PairwiseNodePlanner",
    "single": "SingleNodePlanner",
    "joint": "JointPlanner",
    "horizon": "RecedingHorizonPlanner",
    "random": "RandomPolicy",
    "lawnmower": "LawnmowerPolicy",
}
#: The short names of the planners that decide by mutual information.
INFORMATION_PLANNERS: tuple[str, ...] = ("pairwise", "single", "horizon", "joint")
