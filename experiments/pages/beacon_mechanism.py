"""The section of the ``beacon_v1`` page on why pairwise-node does or does not beat single-node
(:mod:`infoseek.experiments.studies.beacon_mechanism`): the decision-difference table by phase
and the switched planners against the study's single-node and pairwise-node groups.

Every comparison is paired by trial index over the trials both groups hold, so the section can
be drawn while the study's store is still being written. The response is the time to localise
(agent 0's mass within the localisation radius reaches 0.9, censored at the episode length);
each row gives both means, the mean paired difference reference - planner with its standard
error (positive: the planner localises sooner), the one-sided Wilcoxon signed-rank p-value
(planner sooner) and the two-sided one. A last sentence counts the trials in which a switched
planner's agent-0 mass series is pairwise-node's, through its ``k`` pairwise-node steps and over
the whole episode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from infoseek.experiments.analysis import (
    format_p_value,
    times_to_localise,
    wilcoxon_faster,
    wilcoxon_two_sided,
)
from infoseek.experiments.columns import TrialView, read_trials
from infoseek.experiments.decision_differences import (
    DecisionRow,
    format_decisions,
    read_decisions,
)
from infoseek.experiments.decisions import BEACON_SWITCHED_PLANNERS, PAIRWISE_STEPS
from infoseek.experiments.store import read_manifest
from infoseek.experiments.studies.beacon_mechanism import BEACON_DECISIONS, SWITCHED_GROUPS

__all__ = ["PairedTtl", "mechanism_lines", "paired_ttl"]

_ALPHA = 0.05
_SINGLE, _PAIRWISE = ("single", 4), ("pairwise", 4)


@dataclass(frozen=True)
class PairedTtl:
    """The time to localise of a planner against a reference on the trials both hold.

    Attributes:
        trials: Paired trials.
        planner_mean: The planner's mean time to localise over them.
        reference_mean: The reference's.
        gain: Mean paired difference reference - planner (positive: planner sooner).
        gain_se: Its standard error.
        p_sooner: One-sided Wilcoxon signed-rank p-value (planner sooner).
        p_two_sided: Two-sided Wilcoxon signed-rank p-value.
    """

    trials: int
    planner_mean: float
    reference_mean: float
    gain: float
    gain_se: float
    p_sooner: float
    p_two_sided: float


def paired_ttl(planner: dict[int, float], reference: dict[int, float]) -> PairedTtl | None:
    """:class:`PairedTtl` of two ``{trial: time to localise}`` maps (``None`` with fewer than
    two trials in common)."""
    common = sorted(set(planner) & set(reference))
    if len(common) < 2:
        return None
    mine = np.array([planner[k] for k in common])
    theirs = np.array([reference[k] for k in common])
    gain, se, p_sooner = wilcoxon_faster(theirs, mine)
    two_sided = wilcoxon_two_sided(theirs, mine)
    return PairedTtl(
        len(common), float(mine.mean()), float(theirs.mean()), gain, se, p_sooner, two_sided
    )


def _p(p: float) -> str:
    """A p-value as a table cell (:func:`format_p_value` without its ``"= "``)."""
    text = format_p_value(p)
    return text[2:] if text.startswith("= ") else text


def _name(label: str) -> str:
    return BEACON_SWITCHED_PLANNERS.get(label, f"{label} throughout")


def _comparison_rows(
    ttl: dict[tuple[str, int], dict[int, float]], planners: Sequence[str]
) -> list[tuple[str, str, PairedTtl | None]]:
    """``(planner, reference, comparison)``: pairwise-node against single-node (on every
    paired trial, then on the switched planners' trials only), then every switched planner
    against single-node and against pairwise-node."""
    rows = [("pairwise", "single", paired_ttl(ttl[_PAIRWISE], ttl[_SINGLE]))]
    if planners:
        shared = set.intersection(*(set(ttl[label, 4]) for label in planners))
        on_shared = {k: v for k, v in ttl[_PAIRWISE].items() if k in shared}
        rows.append(
            (
                "pairwise",
                "single (the switched planners' trials)",
                paired_ttl(on_shared, ttl[_SINGLE]),
            )
        )
    for label in planners:
        for reference in (_SINGLE, _PAIRWISE):
            rows.append((label, reference[0], paired_ttl(ttl[label, 4], ttl[reference])))
    return rows


def _comparison_table(rows: Sequence[tuple[str, str, PairedTtl | None]]) -> str:
    lines = [
        "| planner (n_v = 4) | against | paired trials | mean ttl, planner | mean ttl, against "
        "| against - planner (steps) | one-sided p (planner sooner) | two-sided p |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, reference, c in rows:
        if c is None:
            lines.append(f"| {_name(label)} | {reference} | < 2 | | | | | |")
            continue
        lines.append(
            f"| {_name(label)} | {reference} | {c.trials} | {c.planner_mean:.2f} "
            f"| {c.reference_mean:.2f} | {c.gain:+.2f} +- {c.gain_se:.2f} "
            f"| {_p(c.p_sooner)} | {_p(c.p_two_sided)} |"
        )
    return "\n".join(lines)


def _decisions_text(rows: Sequence[DecisionRow]) -> str:
    """What the decision table shows, in numbers."""
    parts = []
    for n_agents in sorted({r.n_agents for r in rows}):
        first = [100 * r.differ for r in rows if r.n_agents == n_agents and r.start == 0]
        later = [100 * r.differ for r in rows if r.n_agents == n_agents and r.start > 0]
        cells = [f"{first[0]:.0f} % at step 0"] if first else []
        if later:
            cells.append(f"{min(later):.0f}-{max(later):.0f} % in each later phase")
        parts.append(f"{', '.join(cells)} (n_v = {n_agents})")
    trials = ", ".join(str(t) for t in sorted({r.trials for r in rows if r.start == 0}))
    return (
        f"Along pairwise-node's episodes ({trials} per fleet size; decision trial `k` is the "
        "study's pairwise-node trial `k`), a single-node planner is asked for its choice in the "
        "same state; a choice differs when the commanded accelerations are more than "
        f"{BEACON_DECISIONS.threshold:g} {BEACON_DECISIONS.unit} apart on an axis (10 % of the "
        "per-axis range). Agent-steps on which the choices differ: " + "; ".join(parts) + "."
    )


def _verdict(rows: Sequence[tuple[str, str, PairedTtl | None]]) -> str:
    """The rows whose tests reject at ``_ALPHA``: planner sooner (one-sided), planner later
    (two-sided, negative difference)."""

    def listed(selected: list[str]) -> str:
        return "; ".join(selected) if selected else "none"

    sooner = [
        f"{_name(label)} against {reference}"
        for label, reference, c in rows
        if c is not None and c.p_sooner < _ALPHA
    ]
    later = [
        f"{_name(label)} against {reference}"
        for label, reference, c in rows
        if c is not None and c.p_two_sided < _ALPHA and c.gain < 0
    ]
    return (
        f"Rows where the planner localises sooner at alpha = {_ALPHA:g} (one-sided p): "
        f"{listed(sooner)}. Rows where it localises later (two-sided p < {_ALPHA:g}, negative "
        f"difference): {listed(later)}."
    )


def _same_path_text(trials: Sequence[TrialView], planners: Sequence[str]) -> str:
    """How often each switched planner's agent-0 mass series is pairwise-node's, through step
    ``k`` and over the whole episode, on the trials both hold."""
    pairwise = {t.trial: t.mass_agent0 for t in trials if (t.planner, t.n_agents) == _PAIRWISE}
    parts = []
    for label in planners:
        k = PAIRWISE_STEPS[label]
        mine = {t.trial: t.mass_agent0 for t in trials if (t.planner, t.n_agents) == (label, 4)}
        common = sorted(set(mine) & set(pairwise))
        prefix = sum(np.array_equal(mine[i][: k + 1], pairwise[i][: k + 1]) for i in common)
        whole = sum(np.array_equal(mine[i], pairwise[i]) for i in common)
        parts.append(
            f"{_name(label)}: through step {k} in {prefix} of {len(common)} paired trials, "
            f"over the whole episode in {whole}"
        )
    return (
        "Agent 0's posterior-mass series of a switched planner equals pairwise-node's in the "
        "same trial (" + "; ".join(parts) + ")."
    )


def mechanism_lines(out: Path, main_store: Path) -> list[str]:
    """The section's Markdown blocks (heading, paragraphs, tables), for
    :func:`~infoseek.experiments.pages.markdown.page_text`.

    Args:
        out: The study's directory (``decisions.json``, ``switched/store``).
        main_store: The ``beacon_v1`` study's store (its ``single/4`` and ``pairwise/4``).

    Raises:
        ValueError: No ``decisions.json``, no switched store, or a store of another run
            configuration than the main store.
    """
    decisions = read_decisions(out)  # its episodes are the main store's (--steps, --particles)
    switched = out / "switched" / "store"
    if decisions is None or not (switched / "manifest.json").exists():
        raise ValueError(f"{out}: no decisions.json or no switched/store")
    config = read_manifest(main_store)["config"]
    steps = int(config["steps"])
    mine = read_manifest(switched)["config"]
    keys = ("env", "env_kwargs", "steps", "seed")
    if any(mine[key] != config[key] for key in keys):
        raise ValueError(f"{switched} and {main_store} hold different run configurations")
    trials: list[TrialView] = [*read_trials(main_store), *read_trials(switched)]
    stored = {(t.planner, t.n_agents) for t in trials}
    planners = [label for label, n in SWITCHED_GROUPS if (label, n) in stored]
    groups = [_SINGLE, _PAIRWISE, *((label, 4) for label in planners)]
    ttl = {group: times_to_localise(trials, group[0], group[1], steps) for group in groups}
    rows = _comparison_rows(ttl, planners)
    claim = rows[0][2]
    does = claim is not None and claim.p_sooner < _ALPHA
    return [
        f"## Why pairwise-node {'beats' if does else 'does not beat'} single-node on `beacon_v1`",
        _decisions_text(decisions),
        format_decisions(decisions, BEACON_DECISIONS),
        "Pairwise-node for the first `k` steps, then single-node (`infoseek.experiments."
        "decisions`), on the targets of the study's trials, each paired by trial with the "
        "study's single-node and pairwise-node groups at `n_v = 4` (time to localise in steps; "
        "`+-` one standard error of the paired mean; Wilcoxon signed-rank tests):",
        _comparison_table(rows),
        _verdict(rows),
        _same_path_text(trials, planners),
    ]
