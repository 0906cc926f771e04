"""``infoseek verify DIR``: rerun stored trials from their seeds and compare the records.

A trial is a pure function of its configuration (the store manifest's environment, environment
keyword arguments and episode length), its planner label, its number of agents and its two
seeds (see :mod:`infoseek.experiments.seeds`). Rerunning it with the installed code must
therefore reproduce its stored record, except for the timing fields (:data:`TIMING_FIELDS`),
which measure the machine rather than the result.

The rerun record is brought into stored form (per-step series in float32, as the store keeps
them) and compared field by field. Numbers count as equal within ``|a - b| <= ATOL + RTOL
|b|`` (:data:`RTOL` ``= 1e-5``, :data:`ATOL` ``= 1e-6``): floating-point noise (another BLAS
kernel summing in another order, a value rounded to the other side of a float32 boundary) stays
orders of magnitude below that, while a trial whose decisions changed differs by far more
within a few steps. Each trial is reported as *reproduced* (identical), *equal within
tolerance* (noise) or *diverged*, a diverged one with the first step at which a per-step series
leaves the tolerance. A diverged record was written by other code (an older version of a
planner, say) and should not be mixed with records of the installed code; the command prints
those keys and exits with status 1 if there are any.

A trained policy's label names its model relative to the store (or as a shipped model), so a
store verifies from any checkout; stores written before those labels name an absolute path
(``infoseek migrate DIR`` rewrites them).

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

from infoseek.experiments.executors import execute
from infoseek.experiments.policy_labels import display_name, is_policy, policy_file
from infoseek.experiments.progress import progress_bar
from infoseek.experiments.record import TIMING_FIELDS, TrialRecord
from infoseek.experiments.store import as_stored, encode_record, read_manifest, read_records
from infoseek.experiments.trial import TrialSpec

#: Relative and absolute tolerance of the comparison (module docstring).
RTOL = 1e-5
ATOL = 1e-6


def stored_trial_spec(
    config: Mapping[str, Any],
    record: TrialRecord,
    store: str | os.PathLike[str] = ".",
) -> TrialSpec:
    """The :class:`~infoseek.experiments.trial.TrialSpec` that reproduces a stored record.

    Args:
        config: The store manifest's ``config``.
        record: One stored trial record.
        store: The store's directory (trained-policy labels are relative to it).
    """
    planner = record.planner
    model_file = str(policy_file(planner, store)) if is_policy(planner) else None
    return TrialSpec(
        env=str(config["env"]),
        env_kwargs=dict(config["env_kwargs"]),
        steps=int(config["steps"]),
        planner=planner,
        n_agents=record.n_agents,
        trial=record.trial,
        env_seed=record.env_seed,
        policy_seed=record.policy_seed,
        model_file=model_file,
    )


def _check_model_file(spec: TrialSpec) -> None:
    """Raise ``ValueError`` (naming the group and the path) if a policy's model is missing."""
    if spec.model_file is None or os.path.isfile(spec.model_file):
        return
    hint = ""
    if os.path.isabs(spec.planner.removeprefix("policy:")):  # a store from before portable labels
        hint = "; `infoseek migrate DIR --relocate OLD=NEW` makes its labels portable"
    raise ValueError(
        f"group {display_name(spec.planner)}/{spec.n_agents} ({spec.planner}): no model file "
        f"at {spec.model_file}{hint}"
    )


@dataclass(frozen=True)
class Comparison:
    """How a rerun record compares with its stored record.

    Attributes:
        fields: Fields (timing aside) that differ beyond the tolerance.
        first_step: First step at which a per-step series differs beyond the tolerance
            (``None`` if none does).
        noise: Largest difference found within the tolerance (0.0: identical).
    """

    fields: tuple[str, ...]
    first_step: int | None
    noise: float


def _close(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
        return a == b
    if isinstance(a, int | float) and isinstance(b, int | float):
        return abs(float(a) - float(b)) <= ATOL + RTOL * abs(float(b))
    return a == b


def compare_records(stored: TrialRecord, rerun: TrialRecord) -> Comparison:
    """Compare a rerun record (brought into stored form) with the stored one (module doc)."""
    rerun_row = as_stored([json.loads(encode_record(rerun.to_row()))])[0]
    stored_row = stored.to_row()
    fields = sorted((set(stored_row) | set(rerun_row)) - TIMING_FIELDS)
    differing: list[str] = []
    first_step: int | None = None
    noise = 0.0
    for field in fields:
        a, b = rerun_row.get(field, ...), stored_row.get(field, ...)
        if isinstance(a, list) and isinstance(b, list):
            bad = [t for t, (x, y) in enumerate(zip(a, b, strict=False)) if not _close(x, y)]
            if len(a) != len(b):
                bad.append(min(len(a), len(b)))
            if bad:
                differing.append(field)
                first_step = bad[0] if first_step is None else min(first_step, bad[0])
            noise = max(noise, _noise(a, b))
        elif not _close(a, b):
            differing.append(field)
        else:
            noise = max(noise, _noise([a], [b]))
    return Comparison(tuple(differing), first_step, noise)


def _noise(a: list[Any], b: list[Any]) -> float:
    """Largest difference between paired numbers that are equal within the tolerance."""
    worst = 0.0
    for x, y in zip(a, b, strict=False):
        if isinstance(x, int | float) and isinstance(y, int | float) and _close(x, y):
            worst = max(worst, abs(float(x) - float(y)))
    return worst


@dataclass
class VerifyResult:
    """Outcome of :func:`verify_store`.

    Attributes:
        checked: Number of records rerun and compared.
        differing: Key of every diverged record -> its :class:`Comparison`.
        within_tolerance: Number of records equal only within the tolerance (noise).
        largest_noise: Largest difference among the records within tolerance.
    """

    checked: int
    differing: dict[str, Comparison]
    within_tolerance: int = 0
    largest_noise: float = 0.0


def _selected_records(
    directory: str | os.PathLike[str],
    trials: int | None,
    groups: Sequence[tuple[str, int]] | None,
) -> dict[str, TrialRecord]:
    """The stored records :func:`verify_store` reruns, by key (its arguments).

    Raises:
        ValueError: A requested group is not stored.
    """
    records = read_records(directory)
    stored_groups = {record.group for record in records}
    wanted = stored_groups if groups is None else set(groups)
    missing = sorted(wanted - stored_groups)
    if missing:
        raise ValueError(
            f"{directory}: no stored trials of group(s) "
            + ", ".join(f"{p}/{n}" for p, n in missing)
            + f"; stored: {', '.join(f'{p}/{n}' for p, n in sorted(stored_groups))}"
        )
    return {
        record.key: record
        for record in records
        if record.group in wanted and (trials is None or record.trial < trials)
    }


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
        ValueError: ``trials`` is not positive, a requested group is not stored, or a stored
            trial lacks a field of the record's schema
            (:class:`~infoseek.experiments.record.TrialRecord`).
    """
    if trials is not None and trials < 1:
        raise ValueError(f"--trials must be a positive number of trials, got {trials}")
    config = read_manifest(directory)["config"]
    selected = _selected_records(directory, trials, groups)
    specs = [stored_trial_spec(config, record, directory) for record in selected.values()]
    for spec in specs:
        _check_model_file(spec)
    differing: dict[str, Comparison] = {}
    noisy, largest = 0, 0.0
    bar = progress_bar(len(specs), "verify", progress)
    try:
        for spec, rerun in execute(specs, backend=backend, workers=workers, address=address):
            comparison = compare_records(selected[spec.key], rerun)
            if comparison.fields:
                differing[spec.key] = comparison
            elif comparison.noise > 0:
                noisy += 1
                largest = max(largest, comparison.noise)
            bar.update(1)
    finally:
        bar.close()
    return VerifyResult(
        checked=len(specs),
        differing=dict(sorted(differing.items())),
        within_tolerance=noisy,
        largest_noise=largest,
    )
