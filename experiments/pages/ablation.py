"""The Claim A ablation page (``docs/results/ablation.md``), from the ablation study's directory
(one store per setting, ``ablation.png``, the decisions study's ``decisions.json``)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from infoseek.experiments.decisions import SWITCHED_PLANNERS
from infoseek.experiments.pages.markdown import code_block, display_path, figure, page_text
from infoseek.experiments.pages.provenance import read_provenance, stores_section
from infoseek.experiments.studies import ablation, decisions
from infoseek.experiments.studies.ablation import GapRow

__all__ = ["ablation_page"]

_ALPHA = 0.05
_INTRO = (
    "Around `bearings_v0`'s defaults one setting the paper leaves open varies at a time, with "
    "single-node and pairwise-node on paired trials; trial `k` faces the same target in every "
    "setting and in Fig. 1. The response with low variance is the **mean posterior mass** "
    "within the localisation radius over the episode (agent 0), beside the time to localise; "
    "`p` is a one-sided Wilcoxon signed-rank test (pairwise better), `+-` one standard error "
    'of the paired mean difference, "gap at steps" the mean paired mass difference at those '
    'steps. The rows "pairwise at ... then single" are planners that run pairwise-node for '
    "the first steps and single-node afterwards (`infoseek.experiments.decisions`, usable as "
    "`--planner` factories)."
)
_WHEN = (
    "* **When the gain is made** (panel b, the mean paired mass gap of each setting by step as "
    "a colour map; red: pairwise-node ahead): the gap rises in the first steps and is gone "
    "once both planners have localised."
)
_DECISIONS_NOTE = (
    "\n\n`decisions.json` records the decisions study's rows, not its machine or time."
)


def _fleet_bullet(rows: Sequence[GapRow]) -> str:
    """Claim A across the settings, and the fleet size's effect."""
    pairwise = [r for r in rows if r.planner == "pairwise"]
    failing = [r.label for r in pairwise if r.mass_p >= _ALPHA]
    four = [r.mass_gap_percent for r in pairwise if r.n_agents == 4]
    holds = (
        f"**Claim A holds in every setting** (one-sided p <= {max(r.mass_p for r in pairwise):.2g}"
        " on the mean mass)"
        if not failing
        else f"**Claim A is not supported at alpha = {_ALPHA} in:** {', '.join(failing)}"
    )
    text = (
        f"* {holds}; with four airplanes the gain is between {min(four):.1f} and "
        f"{max(four):.1f} % of single-node's mean mass over every setting of noise, speed, start "
        "spacing and particle count."
    )
    others = [r for r in pairwise if r.factor == "defaults" and r.n_agents != 4]
    for row in others:
        text += (
            f" With `n_v = {row.n_agents}` the gain is {row.mass_gap_percent:+.1f} % (time to "
            f"localise {row.ttl_gap:+.2f} +- {row.ttl_gap_se:.2f} steps)."
        )
    return text


def _switch_bullet(rows: Sequence[GapRow]) -> str:
    """Which decisions make the gain: the switched planners against pairwise-node."""
    default = next(
        r for r in rows if r.factor == "defaults" and r.planner == "pairwise" and r.n_agents == 4
    )
    parts = [
        f"{SWITCHED_PLANNERS[r.planner]}: mass gap {r.mass_gap:+.4f} +- {r.mass_gap_se:.4f}, "
        f"time to localise {r.ttl_gap:+.2f} +- {r.ttl_gap_se:.2f} steps"
        for r in rows
        if r.planner in SWITCHED_PLANNERS
    ]
    return (
        "* **Which decisions make the gain** (panel c): against pairwise-node throughout "
        f"(mass gap {default.mass_gap:+.4f} +- {default.mass_gap_se:.4f}, time to localise "
        f"{default.ttl_gap:+.2f} +- {default.ttl_gap_se:.2f} steps over single-node at "
        f"`n_v = 4`), " + "; ".join(parts) + "."
    )


def _decisions_text(rows: Sequence[decisions.DecisionRow]) -> str:
    """How often pairwise-node decides differently, with the table."""
    first = [r for r in rows if r.start == 0]
    later = [r for r in rows if r.start > 0]
    agree = [100 * (1 - r.differ) for r in later]
    trials = sorted({r.trials for r in rows})
    return "\n\n".join(
        [
            "**How often pairwise-node decides differently**: along pairwise-node episodes "
            f"({', '.join(map(str, trials))} per fleet size), a single-node planner is asked "
            "for its choice in the same state; a choice differs when the turn rates are more "
            f"than {decisions.DIFFERENT_TURN_RATE:g} rad/s apart:",
            decisions.format_decisions(rows),
            "At step 0 (uniform prior) pairwise-node changes "
            + ", ".join(f"{100 * r.differ:.0f} % (n_v = {r.n_agents})" for r in first)
            + " of the vehicles' turns: it fans the team out where single-node sends every "
            f"airplane the same way. Afterwards it agrees with single-node on {min(agree):.0f}-"
            f"{max(agree):.0f} % of the decisions.",
        ]
    )


def ablation_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the ablation page.

    Args:
        results: The ablation study's directory (``<setting>/store``, ``ablation.png``,
            ``decisions.json``).
        page: Where the page is written (the figure is linked relative to it).

    Raises:
        ValueError: ``results`` has no setting's store or no ``decisions.json``.
    """
    results, page = Path(results), Path(page)
    rows = ablation.ablation_rows(results)
    decision_rows = decisions.read_decisions(results)
    if not rows or decision_rows is None:
        raise ValueError(f"{results}: no ablation stores or no decisions.json")
    stores = [results / s.name / "store" for s in ablation.SETTINGS]
    out = display_path(results)
    commands = [
        f"infoseek reproduce ablation --trials {min(r.trials for r in rows)} --out {out} "
        f"--page {display_path(page)}",
        f"infoseek page ablation --results {out} --out {display_path(page)}",
    ]
    return page_text(
        [
            "# Claim A ablation: what the pairwise-node gain depends on, and when it is made",
            figure("Claim A ablation", results / "ablation.png", page),
            _INTRO,
            "## Commands",
            "The trials (one resumable store per setting), the table `ablation.md`, the figure "
            "and the decisions study (kept in `decisions.json`; delete it to recompute it), "
            "then this page from them:",
            code_block("\n".join(commands), "bash"),
            "## Results",
            ablation.format_table(rows),
            "\n".join([_fleet_bullet(rows), _WHEN, _switch_bullet(rows)]),
            _decisions_text(decision_rows),
            stores_section([read_provenance(s) for s in stores if (s / "manifest.json").exists()])
            + _DECISIONS_NOTE,
        ]
    )
