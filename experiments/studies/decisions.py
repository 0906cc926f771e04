"""The decisions study (part of ``infoseek reproduce ablation``): how often the pairwise-node
planner changes the decision the single-node planner would make in the same state.

Pairwise-node (eq. 22) adds to each vehicle's single-node utility (eq. 20) the pairwise terms
with the others' planned observations. Its gain over single-node (Claim A) can only come from
the steps at which that changes the chosen control. This study measures it directly: episodes
of ``bearings_v0`` are driven by the pairwise-node planner (the same seeds as Fig. 1: trial
``k`` uses the environment seed of Fig. 1's trial ``k``), and at every step a single-node
planner (its own seed, its own plan history) is asked for its actions in the same state, on
the same beliefs. An agent-step *differs* when the two turn rates are more than
:data:`DIFFERENT_TURN_RATE` apart. The episodes and their summary are
:mod:`infoseek.experiments.decision_differences`, whose default setting
(:data:`~infoseek.experiments.decision_differences.BEARINGS_DECISIONS`) is this study's; this
module re-exports its functions with this study's trial counts and fleet sizes.

Reported per fleet size and phase of the search (step ranges :data:`PHASES`): the fraction of
agent-steps that differ, with its standard error over trials, and the mean absolute
turn-rate difference. Single-node's choice is not executed, so the states are pairwise-node's.

The counterfactual that goes with it is the switched planner
(:class:`infoseek.experiments.decisions.PairwiseThenSingle`: pairwise-node for the first ``k``
steps, single-node after), which the Claim A ablation
(:mod:`infoseek.experiments.studies.ablation`) runs on the same targets as single-node and
pairwise-node: if it keeps pairwise-node's gain, the gain is made by those first decisions.

The rows are kept in ``OUT/decisions.json`` (:func:`write_decisions`): the study runs its
episodes only when that file is missing.
"""

from __future__ import annotations

from collections.abc import Sequence

from infoseek.experiments.decision_differences import (
    BEARINGS_DECISIONS,
    DecisionRow,
    DecisionSetting,
    format_decisions,
    read_decisions,
    summarise_differences,
    trial_differences,
    write_decisions,
)
from infoseek.experiments.decision_differences import decision_rows as _decision_rows

__all__ = [
    "DECISIONS_ENV",
    "DEFAULT_TRIALS",
    "DIFFERENT_TURN_RATE",
    "FLEETS",
    "PHASES",
    "DecisionRow",
    "decision_rows",
    "format_decisions",
    "read_decisions",
    "summarise_differences",
    "trial_differences",
    "write_decisions",
]

DECISIONS_ENV = BEARINGS_DECISIONS.env
DEFAULT_TRIALS = 20
FLEETS = (2, 4, 10)
PHASES = BEARINGS_DECISIONS.phases
"""Step ranges ``[start, stop)`` of the phases reported."""
DIFFERENT_TURN_RATE = BEARINGS_DECISIONS.threshold
"""rad/s; 10 % of the airplanes' turn-rate range [-0.5, 0.5]."""


def decision_rows(
    trials: int = DEFAULT_TRIALS,
    fleets: Sequence[int] = FLEETS,
    seed: int = 0,
    setting: DecisionSetting = BEARINGS_DECISIONS,
) -> list[DecisionRow]:
    """Every fleet size's rows (runs ``trials`` pairwise episodes per fleet size; see
    :func:`infoseek.experiments.decision_differences.decision_rows`)."""
    return _decision_rows(trials, fleets, seed, setting)
