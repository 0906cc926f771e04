"""``infoseek verify DIR``: rerun stored trials from their seeds and compare the records.

A trial is a pure function of its configuration (the store manifest's environment, environment
keyword arguments and episode length), its planner label, its number of agents and its two
seeds (see :mod:`infoseek.experiments.bench`). Rerunning it with the installed code must
therefore reproduce its stored record exactly, except for the timing fields
(:data:`TIMING_FIELDS`), which measure the machine rather than the result. A record that differs
was written by other code (an older version of a planner, say) and should not be mixed with
records of the installed code: :func:`verify_store` finds such records; the command prints their
keys and exits with status 1 if there are any.

Trials run with planner options passed through the Python API
(:attr:`~infoseek.experiments.bench.BenchPlan.planner_options`) are not described by the store;
``infoseek verify`` reruns every trial with the planners' defaults, as ``infoseek bench`` does.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from infoseek.experiments.bench import TrialSpec, execute, trial_progress_bar
from infoseek.experiments.store import encode_record, read_manifest, read_records

#: Record fields that measure the machine, not the trial (left out of the comparison).
TIMING_FIELDS = frozenset({"wall_time", "plan_time"})


def stored_trial_spec(config: Mapping[str, Any], record: Mapping[str, Any]) -> TrialSpec:
    """The :class:`~infoseek.experiments.bench.TrialSpec` that reproduces a stored record.

    Args:
        config: The store manifest's ``config``.
        record: One stored trial record.
    """
    return TrialSpec(
        env=str(config["env"]),
        env_kwargs=dict(config["env_kwargs"]),
        steps=int(config["steps"]),
        planner=str(record["planner"]),
        n_agents=int(record["n_agents"]),
        trial=int(record["trial"]),
        env_seed=int(record["env_seed"]),
        policy_seed=int(record["policy_seed"]),
    )


def differing_fields(stored: Mapping[str, Any], rerun: Mapping[str, Any]) -> list[str]:
    """Sorted names of the fields (timing fields aside) in which two records differ.

    Both records are compared in their stored JSON form, so a rerun record compares equal to
    the record it reproduces (floats round-trip exactly through JSON).
    """
    rerun = json.loads(encode_record(rerun))
    fields = (set(stored) | set(rerun)) - TIMING_FIELDS
    return sorted(f for f in fields if stored.get(f, ...) != rerun.get(f, ...))


@dataclass
class VerifyResult:
    """Outcome of :func:`verify_store`.

    Attributes:
        checked: Number of records rerun and compared.
        differing: Key of every record that was not reproduced -> the fields that differ.
    """

    checked: int
    differing: dict[str, list[str]]


def verify_store(
    directory: str | os.PathLike[str],
    *,
    trials: int | None = None,
    groups: Sequence[tuple[str, int]] | None = None,
    backend: str = "serial",
    workers: int = 1,
    address: str | None = None,
    progress: bool | None = None,
) -> VerifyResult:
    """Rerun stored trials with the installed code and compare them with their records.

    Args:
        directory: Results directory of a bench/reproduce run.
        trials: Only trials ``0..trials-1`` of every group (default: every stored trial).
        groups: Only these ``(planner, n_agents)`` groups (default: every stored group).
        backend: ``"serial"``, ``"process"`` or ``"ray"``.
        workers: Parallel workers.
        address: Address of an existing Ray cluster (ray backend only).
        progress: Show a tqdm bar (``None``: only on a terminal).

    Returns:
        How many records were checked and which were not reproduced.

    Raises:
        ValueError: ``trials`` is not positive, or a requested group is not stored.
    """
    if trials is not None and trials < 1:
        raise ValueError(f"--trials must be a positive number of trials, got {trials}")
    config = read_manifest(directory)["config"]
    records = read_records(directory)
    stored_groups = {(str(r["planner"]), int(r["n_agents"])) for r in records}
    wanted = stored_groups if groups is None else set(groups)
    missing = sorted(wanted - stored_groups)
    if missing:
        raise ValueError(
            f"{directory}: no stored trials of group(s) "
            + ", ".join(f"{p}/{n}" for p, n in missing)
            + f"; stored: {', '.join(f'{p}/{n}' for p, n in sorted(stored_groups))}"
        )
    selected = {
        r["key"]: r
        for r in records
        if (str(r["planner"]), int(r["n_agents"])) in wanted
        and (trials is None or int(r["trial"]) < trials)
    }
    specs = [stored_trial_spec(config, record) for record in selected.values()]
    differing: dict[str, list[str]] = {}
    bar = trial_progress_bar(len(specs), "verify", progress)
    try:
        for spec, rerun in execute(specs, backend=backend, workers=workers, address=address):
            fields = differing_fields(selected[spec.key], rerun)
            if fields:
                differing[spec.key] = fields
            bar.update(1)
    finally:
        bar.close()
    return VerifyResult(checked=len(specs), differing=dict(sorted(differing.items())))
