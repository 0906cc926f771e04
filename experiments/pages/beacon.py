"""The beacon Monte Carlo pages, from a beacon study's directory: ``docs/results/beacon.md``
(``beacon_v0``: ``OUT/store``, ``OUT/beacon.png``) and ``docs/results/beacon_v1.md``
(``beacon_v1``: ``OUT/store``, ``OUT/beacon_v1.png``, paired curve by curve with the
``beacon_v0`` study's store beside it, and the mechanism section of
:mod:`infoseek.experiments.pages.beacon_mechanism`)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from infoseek.experiments.analysis import GroupSummary, summarise
from infoseek.experiments.columns import read_trials
from infoseek.experiments.pages.beacon_mechanism import mechanism_lines
from infoseek.experiments.pages.markdown import code_block, display_path, figure, page_text, table
from infoseek.experiments.pages.paired_stores import LabelledStore, paired_table
from infoseek.experiments.pages.provenance import provenance_section, read_provenance
from infoseek.experiments.pages.report import baselines_bullet, by_group, metric_paragraph, verdict
from infoseek.experiments.studies.claims import claims_report

__all__ = ["beacon_page", "beacon_v1_page"]

_INTRO = (
    "The paper shows the beacon search by one episode ([Fig. 2](fig2.md)). This study runs "
    "`beacon_v0` with its defaults (four quadrotors unless the group says otherwise) over many "
    "seeded episodes, with the pairwise- and single-node planners with their defaults and the "
    "random and lawnmower baselines; trial `k` of every group faces the same beacon."
)
_INTRO_V1 = (
    "The [beacon study](beacon.md) again on `beacon_v1`, whose filter localises the beacon "
    "sooner than `beacon_v0`'s ([filter settings](beacon_filter.md)) and is no longer the limit "
    "([against an exact posterior](beacon_grid_v1.md)). The trials run as `beacon_v0` with "
    "`beacon_v1`'s two filter settings, which is `beacon_v1` bit for bit "
    "(`tests/test_envs.py`) and keeps the beacon study's seeds: trial `k` of every curve faces "
    "the same beacon here and there, so each curve is also paired with its `beacon_v0` "
    "counterpart."
)

_MECHANISM = (
    "How often the two planners choose differently, phase by phase, and which of pairwise-node's "
    "decisions matter (planners that switch from pairwise- to single-node after a number of "
    "steps) are measured in the last sections."
)


def _commands(results: Path, page: Path, store: Path, trials: int, study: str) -> str:
    """The commands that wrote the store, the figure and this page."""
    out, shown = display_path(results), display_path(store)
    workers = " --workers 2" if study == "beacon_v1" else ""
    lines = [
        f"infoseek reproduce {study} --trials {trials}{workers} --out {out} "
        f"--page {display_path(page)}",
        f"infoseek plot {shown} --out {out}/{study}",
        f"infoseek claims {shown}",
        f"infoseek page {study} --results {out} --out {display_path(page)}",
    ]
    return (
        "The trials, the figure and this page (`reproduce` resumes a stopped run; `plot`, "
        "`claims` and `page` redraw from the store without running anything):\n\n"
        + code_block("\n".join(lines), "bash")
        + f"\n\n`infoseek verify {shown} --trials 2` reruns trials 0-1 of every group from "
        "their seeds and reports any record the installed code does not reproduce."
    )


def _prose(
    claims: list[str], rows: Mapping[tuple[str, int], GroupSummary], mechanism: str = ""
) -> str:
    """The bullets under the tables; their numbers are the summary table's. ``mechanism``: a
    sentence on why Claim A comes out as it does (empty: not measured)."""
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
            f" {mechanism}"
            if mechanism
            else " We have not measured why the pairwise terms buy nothing here (the bearings "
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
        "" if mechanism else "* Not done: a beacon version of the [Claim A ablation](ablation.md).",
    ]
    return "\n".join(line for line in bullets if line)


def beacon_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the beacon page (``beacon_v0``).

    Args:
        results: The beacon study's directory (``store/`` and ``beacon.png`` in it).
        page: Where the page is written (the figure is linked relative to it).
    """
    results, page = Path(results), Path(page)
    store = results / "store"
    title = "# Beacon Monte Carlo (not in the paper)"
    head, tables = _study_sections(results, page, "beacon", _INTRO)
    return page_text([title, *head, *tables, provenance_section(read_provenance(store))])


def beacon_v1_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the ``beacon_v1`` study's page.

    Args:
        results: The study's directory (``store/``, ``beacon_v1.png`` and the mechanism
            study's ``decisions.json`` and ``switched/store`` in it; the ``beacon_v0`` study's
            directory ``beacon`` beside it, whose sections are left out when it is missing).
        page: Where the page is written (the figure is linked relative to it).
    """
    results, page = Path(results), Path(page)
    store, v0_store = results / "store", results.parent / "beacon" / "store"
    head, tables = _study_sections(results, page, "beacon_v1", _INTRO_V1, _MECHANISM)
    stores = {"beacon_v1": store}
    versus_v0: list[str] = []
    if v0_store.is_dir():
        stores["beacon_v0"] = v0_store
        paired = paired_table([LabelledStore("beacon_v1", store)], v0_store, "curve")
        versus_v0 = [
            "## beacon_v1 against beacon_v0, curve by curve",
            "Each row pairs a curve with the same curve of the [beacon_v0 study](beacon.md) "
            f"(`{display_path(v0_store)}`) on the trials both hold.",
            table(paired.header, paired.rows),
        ]
    step_times = [
        "## Time per step outside planning",
        "Each group's trial time (the records' `wall_time`) less its planning time (`plan_time`), "
        "per step: the environment's step (the filters' update, moves and summaries) and the "
        "harness. The trials ran two at a time on the 2-core machine of the provenance "
        "sections, often beside other work, so these are upper bounds on an idle machine's "
        "(the two stores were written on different days by different versions of the code: "
        "their provenance sections); "
        "`infoseek timing --only env_step_beacon_v1_4_planned` measures `beacon_v1`'s step "
        "alone along planned episodes (`env_step_beacon_4` and `env_step_beacon_v1_4`: random "
        "actions, which seldom trigger the moves).",
        _step_time_table(stores),
    ]
    return page_text(
        [
            "# Beacon Monte Carlo on beacon_v1 (not in the paper)",
            *head,
            *tables,
            *versus_v0,
            *step_times,
            *mechanism_lines(results, store),
            provenance_section(read_provenance(store)),
        ]
    )


def _step_time_table(stores: Mapping[str, Path]) -> str:
    """Per store and group: the mean time per step outside planning, in ms."""
    rows = []
    for env, store in stores.items():
        provenance = read_provenance(store)
        planning: dict[tuple[str, int], float] = {}
        steps: dict[tuple[str, int], int] = {}
        for view in read_trials(store):
            key = (view.planner, view.n_agents)
            planning[key] = planning.get(key, 0.0) + float(view.plan_time.sum())
            steps[key] = steps.get(key, 0) + int(view.plan_time.size)
        for group in provenance.groups:
            key = (group.planner, group.n_agents)
            outside = (group.seconds - planning[key]) / steps[key]
            rows.append(
                [
                    env,
                    f"{group.planner}, n_v = {group.n_agents}",
                    str(group.trials),
                    f"{1e3 * planning[key] / steps[key]:.1f}",
                    f"{1e3 * outside:.1f}",
                ]
            )
    header = ["environment", "group", "trials", "planning (ms per step)", "outside planning"]
    return table(header, rows)


def _study_sections(
    results: Path, page: Path, study: str, intro: str, mechanism: str = ""
) -> tuple[list[str], list[str]]:
    """The figure, intro and commands, then the claims tables with their bullets."""
    store = results / "store"
    provenance = read_provenance(store)
    steps = int(provenance.manifest["config"]["steps"])
    report = claims_report(store)
    rows = by_group(summarise(read_trials(store), steps))
    trials = min(group.trials for group in provenance.groups)
    head = [
        figure("Beacon Monte Carlo", results / f"{study}.png", page),
        intro,
        "## Commands",
        _commands(results, page, store, trials, study),
    ]
    tables = [
        "## Tables and tests",
        metric_paragraph(steps),
        code_block(report.text()),
        _prose(report.claims, rows, mechanism),
    ]
    return head, tables
