"""Beyond the paper (``infoseek reproduce horizon``): the receding-horizon planner and the
clairvoyant reference against pairwise-node, on the Fig. 1 store's targets.

The groups are added to the Fig. 1 store (its environment, episode length and seed), so every
comparison with the Fig. 1 curves is paired trial by trial (the same targets): the
receding-horizon planner (``--planner horizon``, its defaults) with 2, 4 and 10 airplanes, and
the clairvoyant Fisher-information reference (:mod:`infoseek.experiments.clairvoyant`, which
reads the true target: not a planner) with 4. The trial counts are those of the committed
store (:data:`HORIZON_GROUPS`); ``--trials N`` runs ``N`` of every group instead. The
clairvoyant Gaussian/Fisher estimate (:mod:`infoseek.experiments.bound`) is computed from the
stored trials, not run.
"""

from __future__ import annotations

from infoseek.experiments.bench import BenchPlan
from infoseek.experiments.clairvoyant import CLAIRVOYANT_LABEL

__all__ = ["HORIZON_ENV", "HORIZON_GROUPS", "horizon_plans"]

HORIZON_ENV = "bearings_v0"
#: ``(planner label, fleet size, trials)`` of the committed study.
HORIZON_GROUPS: tuple[tuple[str, int, int], ...] = (
    ("horizon", 2, 200),
    ("horizon", 4, 724),
    ("horizon", 10, 200),
    (CLAIRVOYANT_LABEL, 4, 1000),
)


def horizon_plans(
    trials: int | None = None,
    steps: int | None = None,
    particles: int | None = None,
    seed: int = 0,
) -> list[BenchPlan]:
    """The benchmark plans of the study: one per trial count (a plan runs the same number of
    trials in each of its groups), in the Fig. 1 store's configuration.

    Args:
        trials: Trials of every group (``None``: :data:`HORIZON_GROUPS`' counts).
        steps: Episode length (``None``: the environment's).
        particles: Particles per belief (``None``: the environment's).
        seed: Root seed.
    """
    by_count: dict[int, list[tuple[str, int]]] = {}
    for planner, n_agents, count in HORIZON_GROUPS:
        by_count.setdefault(count if trials is None else trials, []).append((planner, n_agents))
    return [
        BenchPlan.for_study(HORIZON_ENV, groups, count, steps, particles, seed)
        for count, groups in sorted(by_count.items())
    ]
