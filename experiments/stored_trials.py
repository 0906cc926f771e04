"""The specs of stored trials, for studies that rerun a store's episodes beside something else
(the grid-posterior studies): each trial's :class:`~infoseek.experiments.trial.TrialSpec`, built
from the store's run configuration and the harness's seeds, with the stored record's view.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence

from infoseek.experiments.bench import BenchPlan
from infoseek.experiments.columns import TrialView, read_trials
from infoseek.experiments.store import read_manifest
from infoseek.experiments.trial import TrialSpec

__all__ = ["stored_trial_specs"]


def stored_trial_specs(
    store: str | os.PathLike[str],
    groups: Sequence[tuple[str, int]],
    trials: int,
    *,
    skip_absent: bool = False,
) -> Iterator[tuple[TrialSpec, TrialView]]:
    """The spec of trial ``0..trials-1`` of every group, with its stored view (the harness's
    plan and seeds; a seed that differs from the stored one is an error).

    Args:
        store: The results store.
        groups: ``(planner label, n_agents)`` groups.
        trials: Trials per group.
        skip_absent: Leave out the groups the store does not hold (else they are an error).

    Raises:
        ValueError: ``trials`` below 1, or a group holds fewer trials than asked for.
    """
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise ValueError(f"trials must be a positive integer, got {trials!r}")
    config = read_manifest(store)["config"]
    stored = {(v.planner, v.n_agents, v.trial): v for v in read_trials(store)}
    if skip_absent:
        groups = [(p, n) for p, n in groups if (p, n, 0) in stored]
    for planner, n in groups:
        held = sum(1 for k in range(trials) if (planner, n, k) in stored)
        if held < trials:
            raise ValueError(f"trials: the store holds {held} of {planner}/{n}, asked {trials}")
    plan = BenchPlan(
        env=str(config["env"]),
        env_kwargs=dict(config["env_kwargs"]),
        steps=int(config["steps"]),
        seed=int(config["seed"]),
        groups=list(groups),
        trials=trials,
    )
    for spec in plan.iter_specs(store):
        view = stored[(spec.planner, spec.n_agents, spec.trial)]
        if view.env_seed != spec.env_seed:
            raise ValueError(f"{spec.describe()}: the store has env_seed {view.env_seed}")
        yield spec, view
