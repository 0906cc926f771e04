"""The grid-posterior page (``docs/results/grid_posterior.md``): the particle filter's time to
localise against the exact posterior's on the Fig. 1 episodes, from the study's
``grid_posterior.json`` (:mod:`infoseek.experiments.studies.grid_posterior`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.experiments.analysis import LOCALISED_MASS, format_p_value, wilcoxon_faster
from infoseek.experiments.bound import mass_bound, time_to_localise_bound
from infoseek.experiments.environments import make_env
from infoseek.experiments.pages.markdown import code_block, display_path, page_text, table
from infoseek.experiments.studies.grid_posterior import GridTrial, read_results

__all__ = ["MASS_STEPS", "grid_posterior_page"]

FloatArray = NDArray[np.float64]
#: The steps at which the page compares the mean masses.
MASS_STEPS = (5, 10, 15, 20)
#: Planner comparisons ``(slower, faster)`` of the paired table, where both are present.
_COMPARISONS = (("single", "pairwise"), ("pairwise", "horizon"), ("single", "horizon"))

_INTRO = (
    "Every time to localise in these pages, Fig. 1's metric, is read from agent 0's particle "
    "filter ({particles} particles): the first step at which "
    "the filter's mass within the localisation radius ({radius:g}) of its MMSE estimate "
    "reaches {mass:g}. How much of it is the filter's own error? The study reruns trials "
    "`0..{last}` of the Fig. 1 store's groups with `n_v = {agents}` (the stored episodes: each "
    "rerun's filter masses equal the stored ones bit for bit) and keeps beside agent 0 the "
    "exact posterior on a {cells} x {cells} grid over the domain "
    "(`infoseek.envs.grid_posterior`), fed the same measurements with the same likelihood. "
    "Its mass within the radius of its own MMSE gives the grid's time to localise on the same "
    "data and the same flight. The grid's discretisation error on a mass near {mass:g} is "
    "about 1e-3 (module docstring); `+-` is one standard error of a paired mean difference, "
    "`p` a one-sided Wilcoxon signed-rank test."
)
_CARRIES = (
    "## Which numbers carry the filter's error\n\n"
    "* **Times to localise and mass curves** on the [Fig. 1](fig1.md), [horizon](horizon.md), "
    "[ablation](ablation.md) and [RL](rl.md) pages and in the README are the filter's: each "
    "carries the bias of the first table (the filter minus the exact posterior, on the same "
    "measurements).\n"
    "* **Paired planner comparisons** (Claim A, the horizon planner's gain) use the same "
    "filter in both arms, so they carry only the difference of the two arms' biases: the "
    "third table gives each comparison measured by the filter and by the exact posterior.\n"
    "* **The clairvoyant Gaussian/Fisher estimate** (`infoseek.experiments.bound`, the "
    "dotted curves of Fig. 1) assumes a Gaussian posterior no sharper than the bearings' "
    "Fisher information. The last table counts the trials in which the exact posterior itself "
    "holds more mass than the estimate allows, or localises before the estimate's time to "
    "localise: the assumption fails for the exact posterior too, not only for the filter, so "
    "what the estimate leaves to gain is an estimate, not a limit.\n"
    "* **Beacon numbers** ([beacon](beacon.md), [Fig. 2](fig2.md)) are not covered here: the "
    "beacon's target has a third coordinate (the heading) and its filter a noise floor; the "
    "[beacon grid](beacon_grid.md) page measures its filter against an exact 3-D grid "
    "posterior."
)


def _groups(trials: Sequence[GridTrial]) -> dict[str, list[GridTrial]]:
    """Planner -> its trials in trial order (planners in the order they appear)."""
    groups: dict[str, list[GridTrial]] = {}
    for trial in trials:
        groups.setdefault(trial.planner, []).append(trial)
    return {p: sorted(group, key=lambda t: t.trial) for p, group in groups.items()}


def _difference(slower: FloatArray, faster: FloatArray) -> str:
    """``"mean +- se"`` of ``slower - faster`` and its one-sided p (``faster`` sooner)."""
    mean, se, p = wilcoxon_faster(slower, faster)
    return f"{mean:+.2f} +- {se:.2f} (p {format_p_value(p)})"


def _ttl_table(groups: dict[str, list[GridTrial]], steps: int) -> str:
    rows = []
    for planner, group in groups.items():
        filt = np.array([t.filter_ttl for t in group], dtype=float)
        grid = np.array([t.grid_ttl for t in group], dtype=float)
        rows.append(
            [
                f"`{planner}`",
                str(len(group)),
                f"{filt.mean():.2f}",
                f"{grid.mean():.2f}",
                _difference(grid, filt),
                f"p {format_p_value(wilcoxon_faster(filt, grid)[2])}",
                f"{int(np.sum(filt >= steps))} / {int(np.sum(grid >= steps))}",
                f"{int(np.sum(filt < grid))} / {int(np.sum(filt == grid))} / "
                f"{int(np.sum(filt > grid))}",
            ]
        )
    return table(
        [
            "planner",
            "trials",
            "filter",
            "grid",
            "grid - filter (p: filter sooner)",
            "p: grid sooner",
            "never: filter / grid",
            "filter sooner / same / later",
        ],
        rows,
    )


def _mass_table(groups: dict[str, list[GridTrial]]) -> str:
    rows = []
    for planner, group in groups.items():
        filt = np.array([t.filter_mass for t in group], dtype=float)
        grid = np.array([t.grid_mass for t in group], dtype=float)
        for step in MASS_STEPS:
            diff = filt[:, step] - grid[:, step]
            se = float(np.std(diff, ddof=1) / np.sqrt(diff.size))
            rows.append(
                [
                    f"`{planner}`",
                    str(step),
                    f"{filt[:, step].mean():.3f}",
                    f"{grid[:, step].mean():.3f}",
                    f"{diff.mean():+.3f} +- {se:.3f}",
                ]
            )
    return table(["planner", "step", "filter", "grid", "filter - grid"], rows)


def _comparison_table(groups: dict[str, list[GridTrial]]) -> str:
    rows = []
    for slower, faster in _COMPARISONS:
        if slower not in groups or faster not in groups:
            continue
        a, b = groups[slower], groups[faster]
        common = sorted({t.trial for t in a} & {t.trial for t in b})
        by_a = {t.trial: t for t in a}
        by_b = {t.trial: t for t in b}
        cells = []
        for field in ("filter_ttl", "grid_ttl"):
            x = np.array([getattr(by_a[k], field) for k in common], dtype=float)
            y = np.array([getattr(by_b[k], field) for k in common], dtype=float)
            cells.append(_difference(x, y))
        rows.append([f"`{slower}` - `{faster}`", str(len(common)), *cells])
    return table(["time to localise", "trials", "by the filter", "by the exact posterior"], rows)


def _settings(config: dict[str, Any], n_agents: int) -> Any:
    """The environment's settings (``SearchConfig``) of the store's configuration."""
    env = make_env(str(config["env"]), n_agents=n_agents, **dict(config["env_kwargs"]))
    settings = env.unwrapped.config
    env.close()
    return settings


def _bounds(trials: Sequence[GridTrial], settings: Any, steps: int) -> FloatArray:
    """``(K, steps + 1)`` clairvoyant estimate (:func:`~infoseek.experiments.bound.mass_bound`)
    of each trial, from the environment's settings."""
    return mass_bound(
        np.array([t.truth for t in trials], dtype=float),
        np.asarray(settings.start_positions, dtype=float),
        float(settings.vehicle.speed),
        float(settings.dt),
        float(settings.sensor.sigma),
        float(settings.localization_radius),
        steps,
        float(settings.space.volume),
    )


def _bound_table(groups: dict[str, list[GridTrial]], settings: Any, steps: int) -> str:
    """Per planner: trials whose exact posterior (and filter) holds more mass than the
    clairvoyant estimate at some step >= 1 (step 0 is the prior, the estimate's floor), and
    trials localised before the estimate's time to localise."""
    rows = []
    for planner, group in groups.items():
        bound = _bounds(group, settings, steps)
        limit = time_to_localise_bound(bound)
        cells = []
        for mass_field, ttl_field in (("grid_mass", "grid_ttl"), ("filter_mass", "filter_ttl")):
            mass = np.array([getattr(t, mass_field) for t in group], dtype=float)
            above = np.any(mass[:, 1:] > bound[:, 1 : mass.shape[1]], axis=1)
            early = np.array([getattr(t, ttl_field) for t in group], dtype=float) < limit
            cells += [_share(above), _share(early)]
        rows.append([f"`{planner}`", str(len(group)), *cells])
    return table(
        [
            "planner",
            "trials",
            "exact: above at some step",
            "exact: localised before it",
            "filter: above at some step",
            "filter: localised before it",
        ],
        rows,
    )


def _share(flags: NDArray[np.bool_]) -> str:
    return f"{int(flags.sum())} ({100 * flags.mean():.0f} %)"


def grid_posterior_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the grid-posterior page.

    Args:
        results: The study's directory (``grid_posterior.json`` in it).
        page: Where the page is written.
    """
    results, page = Path(results), Path(page)
    trials, provenance = read_results(results)
    if not trials:
        raise ValueError(f"{results}: the grid-posterior results hold no trials")
    config = provenance["config"]
    steps = int(config["steps"])
    groups = _groups(trials)
    settings = _settings(config, trials[0].n_agents)
    return page_text(
        [
            "# The particle filter against the exact posterior",
            _INTRO.format(
                radius=float(settings.localization_radius),
                particles=int(settings.n_particles),
                mass=LOCALISED_MASS,
                last=min(len(g) for g in groups.values()) - 1,
                agents=trials[0].n_agents,
                cells=provenance["grid"]["cells"],
            ),
            "## Commands",
            "The study (it reruns the episodes of the committed Fig. 1 store, "
            f"`{provenance['store']}`), and this page from its results:",
            code_block(
                f"{provenance['command']} --page {display_path(page)}\n"
                f"infoseek page grid_posterior --results {display_path(results)} "
                f"--out {display_path(page)}",
                "bash",
            ),
            "## Time to localise: filter and exact posterior",
            f"Mean time to localise in steps (censored at {steps}):",
            _ttl_table(groups, steps),
            "## Mean mass within the radius by step",
            _mass_table(groups),
            "## Planner comparisons by the filter and by the exact posterior",
            "Paired mean difference in time to localise (steps), one-sided p that the second "
            "planner localises sooner:",
            _comparison_table(groups),
            "## The clairvoyant Gaussian/Fisher estimate against the exact posterior",
            "Trials in which the mass within the radius exceeds the trial's own estimate "
            "(`infoseek.experiments.bound.mass_bound`) at some step after the first (step 0 is "
            "the prior, the estimate's floor), and trials localised before the step at which "
            "the estimate reaches the localisation mass:",
            _bound_table(groups, settings, steps),
            _CARRIES,
            "## Provenance",
            _provenance_paragraph(results, provenance),
        ]
    )


def _provenance_paragraph(results: Path, provenance: dict[str, Any]) -> str:
    """Who wrote the results, in how long, where, and the grid they used."""
    machine = provenance["machine"]
    return (
        f"`{display_path(results / 'grid_posterior.json')}`: written by "
        f"`{provenance['command']}` in {provenance['wall_time']:g} s with "
        f"{provenance['workers']} worker(s) on {machine['cpu']} ({machine['cpus']} logical "
        f"CPUs, Python {machine['python']}), pinned numerics "
        f"{'on' if provenance['numerics'].get('pinned') else 'off'}; the grid: "
        f"{provenance['grid']['cells']} cells per axis, cells pruned "
        f"{provenance['grid']['prune']:g} nats below the mode."
    )
