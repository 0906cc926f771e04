"""Switched planners: pairwise-node for the first ``k`` steps of an episode, single-node after.

The counterfactual of the decisions study (:mod:`infoseek.experiments.studies.decisions`): if a
planner that runs pairwise-node only for its first ``k`` decisions keeps pairwise-node's gain
over single-node, the gain is made by those first decisions. The Claim A ablation
(:mod:`infoseek.experiments.studies.ablation`) runs it with ``k`` = 1 and 5, through the
factories :func:`pairwise_first_step` and :func:`pairwise_first_5_steps`; the ``beacon_v1``
study (:mod:`infoseek.experiments.studies.beacon_mechanism`) with ``k`` = 10 and 20, through
:func:`pairwise_first_10_steps` and :func:`pairwise_first_20_steps` (on the beacon the two
planners choose alike at step 0 and differ on 12-28 % of the later agent-steps in every phase
up to step 39, so the switch is put after the first quarter and the first half of the 40-step
episode). All are usable as ``infoseek bench --planner MODULE:FACTORY``.

The factories' import paths are the planner labels of their stored trials (the stores
``experiments/results/ablation/default/store`` and
``experiments/results/beacon_v1/switched/store``), so they stay at this path.
"""

from __future__ import annotations

from typing import Any

from infoseek.experiments.policies import make_policy

__all__ = [
    "BEACON_SWITCHED_PLANNERS",
    "PAIRWISE_STEPS",
    "SWITCHED_PLANNERS",
    "PairwiseThenSingle",
    "pairwise_first_10_steps",
    "pairwise_first_20_steps",
    "pairwise_first_5_steps",
    "pairwise_first_step",
]


class PairwiseThenSingle:
    """Pairwise-node for the first ``pairwise_steps`` steps of an episode, single-node after.

    Args:
        env: The environment (parallel API, beliefs in its infos).
        pairwise_steps: Steps planned by pairwise-node (>= 0).
        seed: Seed of both planners' planning-particle streams.
        **options: Options of both planners.
    """

    def __init__(self, env: Any, pairwise_steps: int, seed: int | None = None, **options: Any):
        if isinstance(pairwise_steps, bool) or not isinstance(pairwise_steps, int):
            raise TypeError(f"pairwise_steps must be an int, got {pairwise_steps!r}")
        if pairwise_steps < 0:
            raise ValueError(f"pairwise_steps must be >= 0, got {pairwise_steps}")
        self.pairwise_steps = pairwise_steps
        self.pairwise = make_policy("pairwise", env, seed=seed, **options)
        self.single = make_policy("single", env, seed=seed, **options)
        self.steps_taken = 0

    def act(self, observations: Any, infos: Any) -> dict[str, Any]:
        """This step's actions (see :meth:`infoseek.planners.Planner.act`)."""
        use_pairwise = self.steps_taken < self.pairwise_steps
        self.steps_taken += 1
        return (self.pairwise if use_pairwise else self.single).act(observations, infos)

    def reset(self) -> None:
        """Start a new episode (pairwise-node again)."""
        self.steps_taken = 0
        self.pairwise.reset()
        self.single.reset()


SWITCHED_PLANNERS: dict[str, str] = {
    "infoseek.experiments.decisions:pairwise_first_step": "pairwise at step 0, then single",
    "infoseek.experiments.decisions:pairwise_first_5_steps": "pairwise at steps 0-4, then single",
}
"""Planner labels of the Claim A ablation's switched planners -> their names in tables and
figures (the ablation runs every one of them)."""

BEACON_SWITCHED_PLANNERS: dict[str, str] = {
    "infoseek.experiments.decisions:pairwise_first_10_steps": "pairwise at steps 0-9, then single",
    "infoseek.experiments.decisions:pairwise_first_20_steps": "pairwise at steps 0-19, then single",
}
"""Planner labels of the ``beacon_v1`` study's switched planners
(:mod:`infoseek.experiments.studies.beacon_mechanism`) -> their names in tables; kept apart from
:data:`SWITCHED_PLANNERS`, whose every planner the ablation runs."""

PAIRWISE_STEPS: dict[str, int] = {
    "infoseek.experiments.decisions:pairwise_first_step": 1,
    "infoseek.experiments.decisions:pairwise_first_5_steps": 5,
    "infoseek.experiments.decisions:pairwise_first_10_steps": 10,
    "infoseek.experiments.decisions:pairwise_first_20_steps": 20,
}
"""Planner label of every switched planner -> its pairwise-node steps ``k``."""


def pairwise_first_step(env: Any, seed: int | None = None, **options: Any) -> PairwiseThenSingle:
    """:class:`PairwiseThenSingle` with one pairwise-node step."""
    return PairwiseThenSingle(env, 1, seed=seed, **options)


def pairwise_first_5_steps(env: Any, seed: int | None = None, **options: Any) -> PairwiseThenSingle:
    """:class:`PairwiseThenSingle` with five pairwise-node steps."""
    return PairwiseThenSingle(env, 5, seed=seed, **options)


def pairwise_first_10_steps(
    env: Any, seed: int | None = None, **options: Any
) -> PairwiseThenSingle:
    """:class:`PairwiseThenSingle` with ten pairwise-node steps."""
    return PairwiseThenSingle(env, 10, seed=seed, **options)


def pairwise_first_20_steps(
    env: Any, seed: int | None = None, **options: Any
) -> PairwiseThenSingle:
    """:class:`PairwiseThenSingle` with twenty pairwise-node steps."""
    return PairwiseThenSingle(env, 20, seed=seed, **options)
