"""Why pairwise-node does or does not beat single-node on ``beacon_v1`` (part of the ``beacon_v1``
study): the decisions study and the switched planners on the beacon.

* **Decisions** (:mod:`infoseek.experiments.decision_differences` with
  :data:`BEACON_DECISIONS`): along pairwise-node episodes of ``n_v`` quadrotors
  (:data:`DECISION_FLEETS`), a single-node planner is asked for its actions in the same states;
  an agent-step differs when the two commanded accelerations differ by more than 0.2 units/s^2
  on an axis (10 % of the per-axis range [-1, 1]). The episodes run as ``beacon_v0`` with
  :data:`BEACON_V1_KWARGS` (``beacon_v1`` bit for bit) under the environment id ``beacon_v0``,
  so decision trial ``k`` at ``n_v`` is trial ``k`` of the ``beacon_v1`` study's
  ``pairwise/n_v`` group (same target, same planner seed). Kept in ``OUT/decisions.json`` and
  ``OUT/decisions.md``; a fleet size whose rows are stored is not rerun.
* **Switched planners** (:data:`SWITCHED_GROUPS`, the factories of
  :mod:`infoseek.experiments.decisions`): pairwise-node for the first ``k`` steps, then
  single-node, at ``n_v = 4``, in the resumable bench store ``OUT/switched/store`` with the
  ``beacon_v1`` study's run configuration (:func:`switched_plan`: environment ``beacon_v0``
  with :data:`BEACON_V1_KWARGS`, seed 0, 40 steps), so its trial ``k`` faces the target of trial
  ``k`` of that study's ``single/4`` and ``pairwise/4`` and pairs with them by index.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from infoseek.experiments.bench import BenchPlan, run_bench
from infoseek.experiments.decision_differences import (
    DecisionRow,
    DecisionSetting,
    read_decisions,
    summarise_differences,
    trial_differences,
    write_decisions,
)
from infoseek.experiments.decisions import BEACON_SWITCHED_PLANNERS
from infoseek.experiments.environments import changed_settings
from infoseek.experiments.executors import spawn_pool

__all__ = [
    "BEACON_DECISIONS",
    "BEACON_V1_KWARGS",
    "DECISION_FLEETS",
    "DEFAULT_DECISION_TRIALS",
    "DEFAULT_SWITCHED_TRIALS",
    "SWITCHED_GROUPS",
    "beacon_decision_rows",
    "reproduce_beacon_mechanism",
    "study_settings",
    "switched_plan",
]

#: The environment id the trials run under (it enters the trial seeds).
BEACON_ENV = "beacon_v0"
#: ``beacon_v1``'s registered keywords that differ from ``beacon_v0``'s.
BEACON_V1_KWARGS: dict[str, Any] = changed_settings("beacon_v1", "beacon_v0")
#: The decisions setting: accelerations more than 0.2 units/s^2 apart on an axis differ.
BEACON_DECISIONS = DecisionSetting(
    env=BEACON_ENV,
    env_kwargs=BEACON_V1_KWARGS,
    threshold=0.2,
    quantity="acceleration",
    unit="units/s^2",
    difference="largest per-axis acceleration difference",
    phases=((0, 1), (1, 5), (5, 10), (10, 15), (15, 20), (20, 30), (30, 40)),
)
#: Fleet sizes of the decisions study.
DECISION_FLEETS = (2, 3, 4)
#: Pairwise-node episodes per fleet size in the decisions study.
DEFAULT_DECISION_TRIALS = 30
#: Trials per switched planner.
DEFAULT_SWITCHED_TRIALS = 200
#: The switched planners' groups.
SWITCHED_GROUPS: tuple[tuple[str, int], ...] = tuple(
    (label, 4) for label in BEACON_SWITCHED_PLANNERS
)


def study_settings(steps: int | None = None, particles: int | None = None) -> dict[str, Any]:
    """The environment keywords of the study: :data:`BEACON_V1_KWARGS`, with the episode
    length and the particles per belief where given (``None``: the environment's)."""
    settings: dict[str, Any] = dict(BEACON_V1_KWARGS)
    if particles is not None:
        settings["n_particles"] = particles
    if steps is not None:
        settings["max_cycles"] = steps
    return settings


def switched_plan(
    trials: int = DEFAULT_SWITCHED_TRIALS,
    seed: int = 0,
    steps: int | None = None,
    particles: int | None = None,
) -> BenchPlan:
    """The switched planners' bench plan (module docstring)."""
    return BenchPlan.for_study(
        BEACON_ENV, SWITCHED_GROUPS, trials, steps, particles, seed, BEACON_V1_KWARGS
    )


def beacon_decision_rows(
    n_agents: int,
    trials: int,
    workers: int = 1,
    seed: int = 0,
    setting: DecisionSetting = BEACON_DECISIONS,
) -> list[DecisionRow]:
    """The decision rows of one fleet size (``trials`` pairwise episodes, on ``workers``
    processes)."""
    run = partial(trial_differences, n_agents, seed=seed, setting=setting)
    if workers == 1:
        per_trial: list[np.ndarray] = [run(k) for k in range(trials)]
    else:
        with spawn_pool(workers) as pool:
            per_trial = list(pool.map(run, range(trials)))
    return summarise_differences(n_agents, per_trial, setting)


def reproduce_beacon_mechanism(
    out: Path,
    *,
    decision_trials: int,
    switched_trials: int,
    workers: int,
    fleets: Sequence[int] = DECISION_FLEETS,
    steps: int | None = None,
    particles: int | None = None,
) -> list[Path]:
    """Run what is missing of the study into ``out`` (module docstring): the decision rows of
    every fleet size in ``fleets``, largest first (``OUT/decisions.json`` and ``.md``, rows by
    fleet size, rewritten after each fleet size), then the switched planners' store
    ``OUT/switched/store``.

    Args:
        out: The study's directory.
        decision_trials: Pairwise-node episodes per fleet size.
        switched_trials: Trials per switched planner.
        workers: Worker processes (1: everything in this process).
        fleets: Fleet sizes of the decisions study.
        steps: Episode length (``None``: the environment's, as the study's store).
        particles: Particles per belief (``None``: the environment's).

    Returns:
        The decisions files and the store's directory.

    Raises:
        ValueError: ``decisions.json`` holds another setting, or a fleet size's stored rows
            come from another number of trials than ``decision_trials``.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    plan = switched_plan(switched_trials, 0, steps, particles)  # checks the trial count first
    setting = replace(BEACON_DECISIONS, env_kwargs=study_settings(steps, particles))
    rows = read_decisions(out, setting) or []
    _check_stored_trials(rows, decision_trials)
    paths: list[Path] = []
    for n_agents in sorted(fleets, reverse=True):  # n_v = 4, Claim A's, first
        if any(row.n_agents == n_agents for row in rows):
            continue
        print(f"decisions: single-node's choices along pairwise-node episodes, n_v = {n_agents}")
        rows += beacon_decision_rows(n_agents, decision_trials, workers, setting=setting)
        rows.sort(key=lambda row: (row.n_agents, row.start))
        paths = write_decisions(out, rows, setting)
    if not paths:
        paths = [out / "decisions.md", out / "decisions.json"]
    store = out / "switched" / "store"
    backend = "serial" if workers == 1 else "process"
    result = run_bench(plan, store, backend=backend, workers=workers, progress=False)
    print(f"switched planners: {result.ran} trial(s) run, {result.skipped} already stored")
    return [*paths, store]


def _check_stored_trials(rows: Sequence[DecisionRow], trials: int) -> None:
    """Stored rows come from ``trials`` episodes (their first phase holds every trial)."""
    for row in rows:
        if row.start == 0 and row.trials != trials:
            raise ValueError(
                f"decisions.json holds n_v = {row.n_agents} from {row.trials} trials, not "
                f"{trials}: delete it to rerun the decisions with {trials}"
            )
