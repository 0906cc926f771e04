"""The beacon Monte Carlo page (``docs/results/beacon.md``), from the beacon study's directory
(``OUT/store``, ``OUT/beacon.png``)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from infoseek.experiments.analysis import GroupSummary, summarise
from infoseek.experiments.columns import read_trials
from infoseek.experiments.pages.markdown import code_block, display_path, figure, page_text
from infoseek.experiments.pages.provenance import provenance_section, read_provenance
from infoseek.experiments.pages.report import baselines_bullet, by_group, metric_paragraph, verdict
from infoseek.experiments.studies.claims import claims_report

__all__ = ["beacon_page"]

_INTRO = (
    "The paper shows the beacon search by one episode ([Fig. 2](fig2.md)). This study runs "
    "`beacon_v0` with its defaults (four quadrotors unless the group says otherwise) over many "
    "seeded episodes, with the pairwise- and single-node planners with their defaults and the "
    "random and lawnmower baselines; trial `k` of every group faces the same beacon."
)


def _commands(results: Path, page: Path, store: Path, trials: int) -> str:
    """The commands that wrote the store, the figure and this page."""
    out, shown = display_path(results), display_path(store)
    lines = [
        f"infoseek reproduce beacon --trials {trials} --out {out} --page {display_path(page)}",
        f"infoseek plot {shown} --out {out}/beacon",
        f"infoseek claims {shown}",
        f"infoseek page beacon --results {out} --out {display_path(page)}",
    ]
    return (
        "The trials, the figure and this page (`reproduce` resumes a stopped run; `plot`, "
        "`claims` and `page` redraw from the store without running anything):\n\n"
        + code_block("\n".join(lines), "bash")
        + f"\n\n`infoseek verify {shown} --trials 2` reruns trials 0-1 of every group from "
        "their seeds and reports any record the installed code does not reproduce."
    )


def _prose(claims: list[str], rows: Mapping[tuple[str, int], GroupSummary]) -> str:
    """The bullets under the tables; their numbers are the summary table's."""
    fleets = sorted(n for planner, n in rows if planner == "pairwise")
    trend = ", ".join(f"{rows['pairwise', n].ttl_mean:.1f} steps with {n}" for n in fleets)
    pairwise, single = rows["pairwise", 4], rows["single", 4]
    claim_a = verdict(claims, "Claim A")
    bullets = [
        f"* **Claim B {verdict(claims, 'Claim B')} on the beacon**: pairwise-node's mean time "
        f"to localise is {trend} quadrotors (the `Claim B` lines).",
        f"* **Claim A {claim_a} on the beacon**: mean time to localise {pairwise.ttl_mean:.2f} "
        f"(pairwise-node) against {single.ttl_mean:.2f} steps (single-node) with four "
        "quadrotors; the `Claim A` lines give the paired tests of the time to localise and of "
        "the mean posterior mass. The paper makes no beacon claim for Claim A; its Fig. 2 shows "
        "the pairwise-node planner only."
        + (
            " We have not measured why the pairwise terms buy nothing here (the bearings "
            "ablation's mechanism, a fan-out in the first steps, was not tested on the beacon), "
            "so no reason is claimed."
            if claim_a != "holds"
            else ""
        )
        + f" Pairwise-node planned in {pairwise.plan_ms:.0f} ms per step against single-node's "
        f"{single.plan_ms:.0f} ms (inside the trials).",
        baselines_bullet(rows, 4),
        "* The last lines fit the time to localise against the beacon's initial distance from "
        "the fleet; compare their correlations and residual spreads with the bearings search's "
        "([Fig. 1](fig1.md)).",
        "* Not done: a beacon version of the [Claim A ablation](ablation.md).",
    ]
    return "\n".join(line for line in bullets if line)


def beacon_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the beacon page.

    Args:
        results: The beacon study's directory (``store/`` and ``beacon.png`` in it).
        page: Where the page is written (the figure is linked relative to it).
    """
    results, page = Path(results), Path(page)
    store = results / "store"
    provenance = read_provenance(store)
    steps = int(provenance.manifest["config"]["steps"])
    report = claims_report(store)
    rows = by_group(summarise(read_trials(store), steps))
    trials = min(group.trials for group in provenance.groups)
    return page_text(
        [
            "# Beacon Monte Carlo (not in the paper)",
            figure("Beacon Monte Carlo", results / "beacon.png", page),
            _INTRO,
            "## Commands",
            _commands(results, page, store, trials),
            "## Tables and tests",
            metric_paragraph(steps),
            code_block(report.text()),
            _prose(report.claims, rows),
            provenance_section(provenance),
        ]
    )
