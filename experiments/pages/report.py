"""Reading a study's tables for a page's prose: groups' summaries and claims' verdicts.

The tables themselves are those of :func:`~infoseek.experiments.studies.claims.claims_report`
and :func:`~infoseek.experiments.analysis.summarise`; a page quotes them whole and cites a few
of their numbers in its prose through these functions, so the prose cannot disagree with them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence

from infoseek.experiments.analysis import LOCALISED_MASS, GroupSummary

__all__ = [
    "baselines_bullet",
    "by_group",
    "metric_paragraph",
    "percent_in",
    "verdict",
    "verdict_line",
]


def by_group(rows: Iterable[GroupSummary]) -> dict[tuple[str, int], GroupSummary]:
    """The summary rows keyed by ``(planner, n_agents)``."""
    return {(row.planner, row.n_agents): row for row in rows}


def verdict_line(lines: Sequence[str], prefix: str) -> str:
    """The first line of a claims section (a list of lines or blocks of lines) that starts
    with ``prefix``.

    Raises:
        ValueError: No such line (the store lacks the groups the claim compares).
    """
    for line in (line for block in lines for line in block.splitlines()):
        if line.startswith(prefix):
            return line
    raise ValueError(f"the claims report has no line starting with {prefix!r}")


def verdict(lines: Sequence[str], prefix: str) -> str:
    """``"holds"`` or ``"is not supported"``: the verdict of the claim line ``prefix``."""
    return "holds" if "-> holds" in verdict_line(lines, prefix) else "is not supported"


def metric_paragraph(steps: int) -> str:
    """What the tables of a Monte Carlo store measure (episodes of ``steps`` steps)."""
    return (
        "All groups share their targets trial by trial (trial `k` of every group uses the same "
        "environment seed), so comparisons are paired. Time to localise (ttl) is the first step "
        f"at which agent 0's posterior mass within the localisation radius of its MMSE estimate "
        f"reaches {LOCALISED_MASS:g}, censored at the episode length ({steps} steps); `+-` is "
        "one standard error of the mean paired difference. Planning times per step were "
        "measured inside the trials, with other trials running on the other cores; "
        "`infoseek timing` ([Performance](../performance.md)) gives uncontended ones."
    )


def baselines_bullet(rows: Mapping[tuple[str, int], GroupSummary], n_agents: int) -> str:
    """A bullet with the random and lawnmower baselines' times at ``n_agents`` (empty when the
    store has neither)."""
    baselines = [
        rows[name, n_agents] for name in ("random", "lawnmower") if (name, n_agents) in rows
    ]
    if not baselines:
        return ""
    return (
        f"* The baselines at `n_v = {n_agents}`: "
        + "; ".join(
            f"{row.planner} {row.ttl_mean:.2f} steps ({row.never} of {row.trials} trials never "
            "localised)"
            for row in baselines
        )
        + "."
    )


def percent_in(line: str, pattern: str) -> float:
    """The percentage a claims line states after ``pattern`` (``"(+2.0 % of"`` -> 2.0 with
    ``pattern`` ``"("``; ``"trials: 12.2 % faster"`` -> 12.2 with ``"trials: "``).

    Raises:
        ValueError: No ``pattern`` followed by a percentage in ``line``.
    """
    match = re.search(re.escape(pattern) + r"([+-]?\d+(?:\.\d+)?) %", line)
    if match is None:
        raise ValueError(f"no percentage after {pattern!r} in {line!r}")
    return float(match.group(1))
