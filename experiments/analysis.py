"""Pure functions over trial records: time to localise, curves, paired masses and tests.

Every function takes a sequence of trials, anything with the attributes of :class:`Trial`: the
harness's :class:`~infoseek.experiments.record.TrialRecord` (series as tuples) or the
columnar read of a store, :class:`~infoseek.experiments.columns.TrialView` (series as float64
arrays). Nothing here reads files or builds environments.

* **Time to localise** of a trial: the first step ``t`` at which agent 0's posterior mass within
  the localisation radius of its MMSE estimate reaches :data:`LOCALISED_MASS` (the Fig. 1
  metric); a trial that never gets there is *censored* at the episode length ``T``.
* **Groups** are ``(planner, n_agents)``; trial ``k`` of every group of a run faces the same
  target (:mod:`infoseek.experiments.seeds`), so groups are compared **paired by trial**.
* **Curves** are per-group ``(trials, T + 1)`` matrices of a per-step series, an episode that
  ended early padded with its last value.
* **Tests**: the one-sided Wilcoxon signed-rank test of a paired difference
  (:func:`wilcoxon_faster`), with p-values printed by :func:`format_p_value`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from infoseek.experiments.policy_labels import display_name

__all__ = [
    "LOCALISED_MASS",
    "GroupSummary",
    "Trial",
    "check_pairing",
    "format_p_value",
    "format_summary",
    "groups_of",
    "mass_curves",
    "masses_by_trial",
    "paired_masses",
    "paired_matrix",
    "padded_series",
    "summarise",
    "time_to_localise",
    "times_to_localise",
    "wilcoxon_faster",
    "wilcoxon_two_sided",
]

FloatArray = NDArray[np.float64]
#: Posterior mass within the localisation radius that counts as "localised".
LOCALISED_MASS = 0.9


class Trial(Protocol):
    """The fields of a trial that the analysis reads (see
    :class:`~infoseek.experiments.record.TrialRecord` for their meaning); ``truth``,
    ``radius`` and ``error_agent0`` are ``None`` in stores written before they were
    recorded."""

    @property
    def planner(self) -> str: ...
    @property
    def n_agents(self) -> int: ...
    @property
    def trial(self) -> int: ...
    @property
    def env_seed(self) -> int: ...
    @property
    def radius(self) -> float | None: ...
    @property
    def truth(self) -> Sequence[float] | FloatArray | None: ...
    @property
    def mass_agent0(self) -> Sequence[float | None] | FloatArray: ...
    @property
    def error_agent0(self) -> Sequence[float | None] | FloatArray | None: ...
    @property
    def plan_time(self) -> Sequence[float | None] | FloatArray: ...


# ------------------------------------------------------------------------- time to localise
def time_to_localise(
    mass: Sequence[float | None] | FloatArray, threshold: float = LOCALISED_MASS
) -> int | None:
    """First step index whose posterior mass is ``>= threshold``; ``None`` if never (``None``
    and NaN entries never count)."""
    if isinstance(mass, np.ndarray):
        hits = np.flatnonzero(mass >= threshold)
        return int(hits[0]) if hits.size else None
    for step, value in enumerate(mass):
        if value is not None and value >= threshold:
            return step
    return None


def censored_time_to_localise(mass: Sequence[float] | FloatArray, steps: float) -> float:
    """:func:`time_to_localise` of ``mass``, or ``steps`` (the episode length) if never."""
    ttl = time_to_localise(mass)
    return float(steps) if ttl is None else float(ttl)


def times_to_localise(
    trials: Sequence[Trial], planner: str, n_agents: int, steps: int
) -> dict[int, float]:
    """``{trial: time to localise, censored at steps}`` of one group."""
    times = {}
    for record in trials:
        if record.planner == planner and record.n_agents == n_agents:
            ttl = time_to_localise(record.mass_agent0)
            times[record.trial] = float(steps if ttl is None else ttl)
    return times


def groups_of(trials: Iterable[Trial]) -> set[tuple[str, int]]:
    """The ``(planner, n_agents)`` groups present."""
    return {(record.planner, record.n_agents) for record in trials}


@dataclass(frozen=True)
class GroupSummary:
    """Summary of one ``(planner, n_agents)`` group (one row of the table)."""

    planner: str
    n_agents: int
    trials: int
    ttl_mean: float
    ttl_quartiles: tuple[float, float, float]
    never: int
    final_mass: float
    plan_ms: float


def summarise(
    trials: Iterable[Trial], steps: int, threshold: float = LOCALISED_MASS
) -> list[GroupSummary]:
    """Per-group time to localise (censored at ``steps``), final mass and planning time."""
    groups: dict[tuple[str, int], list[Trial]] = {}
    for record in trials:
        groups.setdefault((record.planner, record.n_agents), []).append(record)
    rows = []
    for (planner, n_agents), members in sorted(groups.items()):
        times = [time_to_localise(r.mass_agent0, threshold) for r in members]
        censored = np.array([steps if t is None else t for t in times], dtype=float)
        final = np.array([_last(r.mass_agent0) for r in members], dtype=float)
        plan = np.concatenate([np.asarray(r.plan_time, dtype=float) for r in members])
        q25, q50, q75 = np.percentile(censored, [25, 50, 75])
        rows.append(
            GroupSummary(
                planner=planner,
                n_agents=n_agents,
                trials=len(members),
                ttl_mean=float(censored.mean()),
                ttl_quartiles=(float(q25), float(q50), float(q75)),
                never=sum(t is None for t in times),
                final_mass=float(final.mean()),
                plan_ms=1e3 * float(np.mean(plan)) if plan.size else math.nan,
            )
        )
    return rows


def _last(series: Sequence[float | None] | FloatArray) -> float:
    value = series[-1]
    return math.nan if value is None else float(value)


def format_summary(rows: Sequence[GroupSummary], steps: int) -> str:
    """The summary table as text (planners by their whole readable name,
    :func:`~infoseek.experiments.policy_labels.display_name`)."""
    labels = [display_name(row.planner) for row in rows]
    width = max([16, *(len(label) for label in labels)])
    header = (
        f"{'planner':<{width}} {'agents':>6} {'trials':>6} {'ttl mean':>8} {'q25':>6} "
        f"{'median':>6} {'q75':>6} {'never':>5} {'final mass':>10} {'plan ms/step':>12}"
    )
    lines = [
        f"time to localise: first step with posterior mass >= {LOCALISED_MASS:g} within the "
        f"localisation radius (agent 0); never-localised trials censored at {steps}",
        header,
        "-" * len(header),
    ]
    for label, row in zip(labels, rows, strict=True):
        q25, q50, q75 = row.ttl_quartiles
        lines.append(
            f"{label:<{width}} {row.n_agents:>6d} {row.trials:>6d} {row.ttl_mean:>8.2f} "
            f"{q25:>6.1f} {q50:>6.1f} {q75:>6.1f} {row.never:>5d} {row.final_mass:>10.3f} "
            f"{row.plan_ms:>12.2f}"
        )
    return "\n".join(lines)


# ---------------------------------------------------------------------------------- curves
def padded_series(values: Sequence[float | None] | FloatArray, length: int) -> FloatArray:
    """``(length,)`` float array of a trial's per-step series: ``None`` becomes NaN, an episode
    that ended early is padded with its last value, a longer one cut."""
    if isinstance(values, np.ndarray):
        series = values.astype(float)
    else:
        series = np.array([np.nan if v is None else v for v in values], dtype=float)
    if series.size < length:
        series = np.concatenate([series, np.full(length - series.size, series[-1])])
    return series[:length]


def mass_curves(
    trials: Sequence[Trial], field: str = "mass_agent0"
) -> dict[tuple[str, int], FloatArray]:
    """Per-group matrices of a per-step series.

    Args:
        trials: Trial records.
        field: The per-step series to collect (an attribute of the records).

    Returns:
        ``(planner, n_agents) -> (n_trials, T + 1)`` array in the order the groups first
        appear, shorter trials padded with their last value (``None`` entries become NaN).
    """
    grouped: dict[tuple[str, int], list[Any]] = {}
    for record in trials:
        grouped.setdefault((record.planner, record.n_agents), []).append(getattr(record, field))
    curves = {}
    for key, rows in grouped.items():
        length = max(len(row) for row in rows)
        curves[key] = np.array([padded_series(row, length) for row in rows])
    return curves


def masses_by_trial(
    trials: Sequence[Trial], planner: str, n_agents: int, length: int
) -> dict[int, FloatArray]:
    """``{trial: (length,) mass series of agent 0}`` of one group (:func:`padded_series`)."""
    return {
        record.trial: padded_series(record.mass_agent0, length)
        for record in trials
        if record.planner == planner and record.n_agents == n_agents
    }


def paired_masses(
    trials: Sequence[Trial], base: str, other: str, n_agents: int, steps: int
) -> tuple[list[int], FloatArray, FloatArray]:
    """``(trials, base masses, other masses)``: the trials both groups hold, ascending, and their
    ``(trials, steps + 1)`` mass series of agent 0."""
    a = masses_by_trial(trials, base, n_agents, steps + 1)
    b = masses_by_trial(trials, other, n_agents, steps + 1)
    common = sorted(set(a) & set(b))
    shape = (len(common), steps + 1)
    return (
        common,
        np.array([a[k] for k in common]).reshape(shape),
        np.array([b[k] for k in common]).reshape(shape),
    )


# ----------------------------------------------------------------------------------- tests
def paired_matrix(groups: Sequence[dict[int, float]]) -> FloatArray:
    """``(trials, groups)`` matrix of per-trial values over the trials every group has."""
    common = sorted(set.intersection(*(set(g) for g in groups)))
    return np.array([[g[t] for g in groups] for t in common], dtype=float).reshape(
        len(common), len(groups)
    )


def check_pairing(trials: Iterable[Trial]) -> None:
    """Raise ``ValueError`` unless every trial index has one environment seed across groups."""
    seeds: dict[int, int] = {}
    for record in trials:
        if seeds.setdefault(record.trial, record.env_seed) != record.env_seed:
            raise ValueError(
                f"trial {record.trial} has different environment seeds across groups: the "
                "store's groups are not paired"
            )


def format_p_value(p: float) -> str:
    """``"= 0.0123"``-style text of a p-value; one that underflowed to 0 prints as a bound."""
    if p <= 0.0:  # below the smallest normal double: say so instead of claiming p = 0
        return f"< {np.finfo(np.float64).tiny:.3g}"
    return f"= {p:.3g}"


def wilcoxon_faster(slower: FloatArray, faster: FloatArray) -> tuple[float, float, float]:
    """One-sided Wilcoxon signed-rank test that ``faster`` localises sooner than ``slower``.

    Returns:
        ``(mean difference slower - faster, its standard error, p-value)``.
    """
    difference = slower - faster
    stderr = float(np.std(difference, ddof=1) / np.sqrt(difference.size))
    if not np.any(difference != 0):
        return 0.0, stderr, 1.0
    from scipy import stats  # imported here: about 0.4 s, which every command paid at start-up

    result = stats.wilcoxon(slower, faster, alternative="greater", zero_method="wilcox")
    return float(np.mean(difference)), stderr, float(result.pvalue)


def wilcoxon_two_sided(first: FloatArray, second: FloatArray) -> float:
    """Two-sided Wilcoxon signed-rank p-value of paired samples (zero differences dropped);
    1.0 when every pair is equal."""
    if not np.any(first != second):
        return 1.0
    from scipy import stats

    return float(stats.wilcoxon(first, second).pvalue)
