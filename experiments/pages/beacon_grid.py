"""The beacon grid page (``docs/results/beacon_grid.md``): the beacon's particle filter against
the exact 3-D grid posterior on stored beacon episodes, from the study's ``beacon_grid.json``
(and the resolution check's ``beacon_grid_halved.json`` where present;
:mod:`infoseek.experiments.studies.beacon_grid`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.experiments.analysis import LOCALISED_MASS, format_p_value, wilcoxon_faster
from infoseek.experiments.pages.markdown import code_block, display_path, page_text, table
from infoseek.experiments.studies.beacon_grid import (
    HALVED_FILE,
    RESULTS_FILE,
    BeaconGridTrial,
    read_results,
)

__all__ = ["STEPS_SHOWN", "beacon_grid_page"]

FloatArray = NDArray[np.float64]
#: Mean distance of a point uniform in a unit square from its centre,
#: (sqrt 2 + log(1 + sqrt 2)) / 6.
_CELL_FLOOR = (np.sqrt(2.0) + np.log1p(np.sqrt(2.0))) / 6.0
#: The steps at which the page shows mass and error.
STEPS_SHOWN = (0, 5, 10, 15, 20, 25, 30, 35, 40)

_INTRO = (
    "The beacon studies' time to localise is read from agent 0's particle filter "
    "({particles} particles, noise floor `filter_max_snr` = {floor:g}): the first step at which "
    "the filter's mass within the localisation radius ({radius:g}) of its MMSE position reaches "
    "{mass:g}. The study reruns trials `0..{last}` of the store's groups (the stored episodes: "
    "each rerun's filter masses and errors equal the stored ones bit for bit) and keeps beside "
    "agent 0 the exact posterior of the beacon `(x, y, psi)` on a {cells} x {cells} x {psi} "
    "grid (`infoseek.envs.oriented_grid_posterior`: position cells of {side:g} units, "
    "orientation cells of pi/{psi} over `[0, pi)`, which the beacon likelihood's symmetry "
    "`psi -> psi + pi` makes enough), fed the same measurements with the same likelihood (the "
    "filters', floor included), cells more than {prune:g} nats below the mode dropped. Its "
    "mass within the radius of its own MMSE gives the exact posterior's time to localise on "
    "the same data and the same flight. `+-` is one standard error of a paired mean "
    "difference, `p` a one-sided Wilcoxon signed-rank test."
)


def _groups(trials: Sequence[BeaconGridTrial]) -> dict[str, list[BeaconGridTrial]]:
    """``planner/n`` -> its trials in trial order (groups in the order they appear)."""
    groups: dict[str, list[BeaconGridTrial]] = {}
    for trial in trials:
        groups.setdefault(f"{trial.planner}/{trial.n_agents}", []).append(trial)
    return {name: sorted(group, key=lambda t: t.trial) for name, group in groups.items()}


def _series(group: Sequence[BeaconGridTrial], field: str) -> FloatArray:
    return np.array([getattr(t, field) for t in group], dtype=float)


def _false_fixes(group: Sequence[BeaconGridTrial], who: str, radius: float, steps: int) -> int:
    """Trials localised (before ``steps``) with the MMSE farther than ``radius`` from the
    target at the step of localisation."""
    count = 0
    for trial in group:
        ttl = getattr(trial, f"{who}_ttl")
        if ttl < steps and getattr(trial, f"{who}_error")[ttl] > radius:
            count += 1
    return count


def _ttl_table(groups: dict[str, list[BeaconGridTrial]], steps: int, radius: float) -> str:
    rows = []
    for name, group in groups.items():
        filt, grid = _series(group, "filter_ttl"), _series(group, "grid_ttl")
        mean, se, p = wilcoxon_faster(filt, grid)
        rows.append(
            [
                f"`{name}`",
                str(len(group)),
                f"{filt.mean():.2f}",
                f"{grid.mean():.2f}",
                f"{mean:+.2f} +- {se:.2f} (p {format_p_value(p)})",
                f"{int(np.sum(grid < filt))} / {int(np.sum(grid == filt))} / "
                f"{int(np.sum(grid > filt))}",
                f"{int(np.sum(filt >= steps))} / {int(np.sum(grid >= steps))}",
                f"{_false_fixes(group, 'filter', radius, steps)} / "
                f"{_false_fixes(group, 'grid', radius, steps)}",
            ]
        )
    return table(
        [
            "group",
            "trials",
            "filter",
            "exact",
            "filter - exact (p: exact sooner)",
            "exact sooner / same / later",
            f"never localised in {steps} steps: filter / exact",
            f"localised > {radius:g} from the target: filter / exact",
        ],
        rows,
    )


def _quartiles(values: FloatArray) -> str:
    q1, q2, q3 = np.percentile(values, [25, 50, 75])
    return f"{values.mean():.3f} ({q1:.3f}, {q2:.3f}, {q3:.3f})"


def _by_step_table(groups: dict[str, list[BeaconGridTrial]]) -> str:
    rows = []
    for name, group in groups.items():
        series = {
            field: _series(group, field)
            for field in ("filter_mass", "grid_mass", "filter_error", "grid_error")
        }
        for step in STEPS_SHOWN:
            if step >= series["filter_mass"].shape[1]:
                continue
            rows.append(
                [f"`{name}`", str(step), *(_quartiles(s[:, step]) for s in series.values())]
            )
    return table(
        [
            "group",
            "step",
            "filter mass",
            "exact mass",
            "filter MMSE error",
            "exact MMSE error",
        ],
        rows,
    )


def _orientation_table(groups: dict[str, list[BeaconGridTrial]]) -> str:
    rows = []
    for name, group in groups.items():
        psi = _series(group, "grid_psi_error")
        localised = _series(group, "grid_mass") >= LOCALISED_MASS
        cells = []
        for step in STEPS_SHOWN[1:]:
            if step >= psi.shape[1]:
                continue
            held = localised[:, step]
            median = f"{np.median(psi[held, step]):.3f}" if held.any() else "-"
            cells.append([f"`{name}`", str(step), str(int(held.sum())), median])
        rows += cells
    return table(["group", "step", "trials localised at the step", "median psi error (rad)"], rows)


def _resolution_section(
    results: Path, trials: Sequence[BeaconGridTrial], provenance: dict[str, Any]
) -> list[str]:
    """The resolution check's table (empty without its results file)."""
    if not (results / HALVED_FILE).is_file():
        return []
    halved, halved_provenance = read_results(results, HALVED_FILE)
    by_key = {(t.planner, t.n_agents, t.trial): t for t in trials}
    rows = []
    worst = np.zeros(3)
    for fine in halved:
        base = by_key.get((fine.planner, fine.n_agents, fine.trial))
        if base is None:
            continue
        mass = np.abs(np.subtract(fine.grid_mass, base.grid_mass))
        held = np.maximum(np.array(base.grid_mass), np.array(fine.grid_mass)) >= 0.5
        error = np.abs(np.subtract(fine.grid_error, base.grid_error))
        error_held = float(error[held].max()) if held.any() else 0.0
        worst = np.maximum(worst, [mass.max(), error_held, abs(fine.grid_ttl - base.grid_ttl)])
        rows.append(
            [
                f"`{fine.planner}/{fine.n_agents}` {fine.trial}",
                f"{base.grid_ttl} / {fine.grid_ttl}",
                f"{mass.max():.4f}",
                f"{float(np.mean(mass)):.5f}",
                f"{error_held:.4f}",
                f"{base.grid_error[-1]:.4f} / {fine.grid_error[-1]:.4f}",
                f"{fine.wall_time:g} s",
            ]
        )
    grid, fine_grid = provenance["grid"], halved_provenance["grid"]
    return [
        "## Resolution check",
        f"The same episodes on a grid with every cell halved ({fine_grid['cells']} x "
        f"{fine_grid['cells']} x {fine_grid['orientation_cells']}, eight times the cells; "
        f"`{halved_provenance['command']}`) against the study's "
        f"({grid['cells']} x {grid['cells']} x {grid['orientation_cells']}). The MMSE error is "
        "compared at the steps where either grid holds a mass of at least 0.5 within the "
        "radius (before that the MMSE of a broad posterior is not a location):",
        table(
            [
                "trial",
                "exact time to localise: study / halved",
                "max abs mass difference",
                "mean abs mass difference",
                "max abs MMSE error difference (mass >= 0.5)",
                "MMSE error at the end: study / halved",
                "halved grid's rerun",
            ],
            rows,
        ),
        f"Largest differences over these trials: mass {worst[0]:.4f}, MMSE error "
        f"{worst[1]:.4f} units, time to localise {worst[2]:.0f} steps.",
    ]


def beacon_grid_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the beacon grid page.

    Args:
        results: The study's directory (``beacon_grid.json`` in it).
        page: Where the page is written.
    """
    results, page = Path(results), Path(page)
    trials, provenance = read_results(results)
    if not trials:
        raise ValueError(f"{results}: the beacon grid results hold no trials")
    steps = int(provenance["config"]["steps"])
    groups = _groups(trials)
    settings = _settings(provenance["config"], trials[0].n_agents)
    radius = float(settings.localization_radius)
    side = float(settings.space.high[0] - settings.space.low[0]) / provenance["grid"]["cells"]
    return page_text(
        [
            "# The beacon's particle filter against the exact posterior",
            _intro(settings, provenance["grid"], groups, side),
            "## Commands",
            f"The study (it reruns the episodes of `{provenance['store']}`), the resolution "
            "check, and this page from their results:",
            code_block(
                f"{provenance['command']} --page {display_path(page)}\n"
                f"infoseek page beacon_grid --results {display_path(results)} "
                f"--out {display_path(page)}",
                "bash",
            ),
            "## Time to localise: filter and exact posterior",
            f"Mean time to localise in steps (censored at {steps}); a trial counts as "
            f"localised far from the target when the MMSE is more than {radius:g} from it at "
            "the step it localises:",
            _ttl_table(groups, steps, radius),
            *_by_step_section(groups, side),
            "## The exact posterior's orientation",
            "Axial error of the exact posterior's orientation estimate (the axial mean), median "
            f"over the trials whose exact posterior holds at least {LOCALISED_MASS:g} within the "
            "radius at that step:",
            _orientation_table(groups),
            *_resolution_section(results, trials, provenance),
            "## Provenance",
            _provenance_paragraph(results, trials, provenance),
        ]
    )


def _intro(
    settings: Any, grid: dict[str, Any], groups: dict[str, list[BeaconGridTrial]], side: float
) -> str:
    """The page's opening paragraph: the filter, the trials rerun and the exact posterior's
    ``grid`` (of cells ``side`` units wide) from the environment's ``settings``."""
    return _INTRO.format(
        particles=int(settings.n_particles),
        floor=float(settings.filter_sensor.max_snr),
        radius=float(settings.localization_radius),
        mass=LOCALISED_MASS,
        last=min(len(g) for g in groups.values()) - 1,
        cells=grid["cells"],
        psi=grid["orientation_cells"],
        side=side,
        prune=grid["prune"],
    )


def _by_step_section(groups: dict[str, list[BeaconGridTrial]], side: float) -> list[str]:
    """Mass within the radius and MMSE error by step, with the grid's error floor for cells
    ``side`` units wide."""
    return [
        "## Mass within the radius and MMSE error by step",
        "Mean (quartiles 25 %, 50 %, 75 %) over the trials; the mass is within the radius "
        "of each posterior's own MMSE position, the error that position's distance to the "
        "target. Once a posterior is narrower than a cell, the exact MMSE is a weighted "
        "mean of a few cell centres, and its error is then about the target's distance to "
        f"the nearest centre ({_CELL_FLOOR * side:.3f} units on average for a target "
        "uniform in its cell), a floor of the grid, not of the posterior; the filter's "
        "particles have no such floor:",
        _by_step_table(groups),
    ]


def _provenance_paragraph(
    results: Path, trials: Sequence[BeaconGridTrial], provenance: dict[str, Any]
) -> str:
    """Who wrote the results, how long the reruns took, where, and how often the truth's cell
    stayed active."""
    machine = provenance["machine"]
    walls = np.array([t.wall_time for t in trials])
    return (
        f"`{display_path(results / RESULTS_FILE)}`: written by `{provenance['command']}` "
        f"in {provenance['wall_time']:g} s (a rerun: median {np.median(walls):.1f} s, "
        f"longest {walls.max():.1f} s, planner and grid) with {provenance['workers']} "
        f"worker(s) on {machine['cpu']} ({machine['cpus']} logical CPUs, Python "
        f"{machine['python']}), pinned numerics "
        f"{'on' if provenance['numerics'].get('pinned') else 'off'}; the truth's grid cell "
        f"was still active at the end in {sum(t.truth_active for t in trials)} of "
        f"{len(trials)} trials."
    )


def _settings(config: dict[str, Any], n_agents: int) -> Any:
    """The environment's settings (``SearchConfig``) of the store's configuration."""
    from infoseek.experiments.environments import make_env

    env = make_env(str(config["env"]), n_agents=n_agents, **dict(config["env_kwargs"]))
    settings = env.unwrapped.config
    env.close()
    return settings
