"""The paper's Fig. 1 from a results store (``infoseek plot DIR``).

Fig. 1 of Hoffmann, Waslander & Tomlin (2006) shows, against the time step ``t``, the mean and
the quartile bars over trials of the probability that the true target is within 1 unit of the
MMSE estimate, i.e. the posterior mass ``m_t = sum_j w_j [||x_j - xhat|| <= r]`` of the belief
within the localisation radius ``r`` of its MMSE position estimate ``xhat`` (eq. 12). The store
records it per step for agent 0's belief (``mass_agent0``, :mod:`infoseek.experiments.record`).

Panels, each drawn only if the store has its data:

* (a) ``n_v = 4``: single-node approximation dashed (orange), pairwise-node approximation solid
  (blue), and the random (dotted) and lawnmower (dash-dot) baselines where the store has them;
* (b) pairwise-node approximation for every stored fleet size (the paper: 2, 3, 4 and 10).

A store with neither (e.g. only random or lawnmower trials) gets one panel with every stored
(planner, fleet size) curve instead. Curves are the per-step mean; the bars span the 25th to
75th percentile (the interquartile range), drawn every few steps and offset slightly per curve
so they stay readable, and the legend says so (:data:`IQR_LABEL`): the mass of most trials is
near 0 or near 1, so a mean can lie outside its own bar. In panel (a) only the planners of the
paper's claim (single- and pairwise-node) get bars. Panel (c) shades one standard error of
the paired mean (:data:`SE_LABEL`). Every drawn artist carries a ``gid`` naming the legend
entry that explains it (``"frame"`` for reference lines), which the tests use to check that
the legend names every kind of mark. Trials that ended before the others (early termination)
are extended with their last value.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from infoseek.experiments.analysis import Trial, mass_curves, paired_masses
from infoseek.experiments.clairvoyant import CLAIRVOYANT_LABEL
from infoseek.experiments.columns import read_trials
from infoseek.experiments.store import read_manifest

PAPER_FLEET_SIZES: tuple[int, ...] = (2, 3, 4, 10)
#: Legend entry of the quartile bars.
IQR_LABEL = "bars: 25th-75th percentile of the trials\n(the mean may lie outside them)"
#: Legend entry of the standard-error bands of panel (c).
SE_LABEL = "band: +- 1 standard error of the paired mean"
#: Planners of panel (a) that get quartile bars.
PANEL_A_BARS = ("single", "pairwise")


def _draw_group(
    axes: Any,
    matrix: np.ndarray,
    label: str,
    *,
    linestyle: str = "-",
    color: Any = None,
    offset: float = 0.0,
    bars: bool = True,
) -> None:
    steps = np.arange(matrix.shape[1])
    mean = np.nanmean(matrix, axis=0)
    (line,) = axes.plot(steps, mean, linestyle=linestyle, color=color, label=label, lw=1.6)
    line.set_gid(label)
    if not bars:
        return
    q25, q75 = np.nanpercentile(matrix, [25, 75], axis=0)
    every = max(1, matrix.shape[1] // 12)
    marks = steps[::every]
    # Quartile bars span [q25, q75]; the mean of a skewed distribution may lie outside them,
    # so they are drawn as their own segments, not as error bars around the mean.
    axes.vlines(
        marks + offset, q25[::every], q75[::every], colors=line.get_color(), lw=1.0, gid=IQR_LABEL
    )
    for level in (q25[::every], q75[::every]):
        axes.plot(
            marks + offset,
            level,
            linestyle="none",
            marker="_",
            ms=5,
            color=line.get_color(),
            gid=IQR_LABEL,
        )


def _draw_paired_differences(
    axes: Any, records: Sequence[Trial], sizes: Sequence[int], base: str, other: str
) -> None:
    """Mean paired mass difference ``other - base`` per step (one line per fleet size, over
    the trials both groups hold) with a band of one standard error either side."""
    steps = max(len(r.mass_agent0) for r in records) - 1
    for position, n_agents in enumerate(sizes):
        trials, a, b = paired_masses(records, base, other, n_agents, steps)
        difference = b - a
        mean = np.nanmean(difference, axis=0)
        se = np.nanstd(difference, axis=0, ddof=1) / np.sqrt(len(trials))
        color = f"C{position % 10}"
        x = np.arange(mean.size)
        axes.fill_between(x, mean - se, mean + se, color=color, alpha=0.25, lw=0, gid=SE_LABEL)
        label = f"$n_v = {n_agents}$ ({len(trials)} pairs)"
        axes.plot(x, mean, color=color, lw=1.6, label=label, gid=label)
    axes.axhline(0.0, color="k", lw=0.8, gid="frame")
    axes.set_title(_PANEL_TITLES["c"])
    axes.set_xlabel("time step")
    axes.set_ylabel("mass difference (mean +- 1 SE)")
    axes.grid(alpha=0.3)
    from matplotlib.patches import Patch

    handles, labels = axes.get_legend_handles_labels()
    band = Patch(facecolor="0.5", alpha=0.25, label=SE_LABEL)
    axes.legend([*handles, band], [*labels, SE_LABEL], loc="upper right", fontsize="small")


def _style(axes: Any, title: str, radius: float) -> None:
    """Title, axis labels, grid and the legend (with an entry for the quartile bars if any)."""
    from matplotlib.lines import Line2D

    axes.set_title(title)
    axes.set_xlabel("time step")
    axes.set_ylabel(f"P(target within {radius:g} of MMSE estimate)")
    axes.set_ylim(-0.02, 1.02)
    axes.grid(alpha=0.3)
    handles, labels = axes.get_legend_handles_labels()
    if any(artist.get_gid() == IQR_LABEL for artist in axes.collections):
        handles.append(Line2D([], [], color="0.3", marker="|", ms=11, mew=1.2, ls="none"))
        labels.append(IQR_LABEL)
    # below the axes: inside, it would hide curves or bars wherever it went
    axes.legend(
        handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize="small"
    )


def fig1_panels(groups: Sequence[tuple[str, int]]) -> list[tuple[str, list[tuple[str, int]]]]:
    """Which panels of Fig. 1 the stored groups allow, and their curves.

    Args:
        groups: The stored ``(planner, n_agents)`` groups.

    Returns:
        ``[(panel id, [(planner, n_agents), ...]), ...]`` with panel ids ``"a"`` (single,
        pairwise and, where stored, the random and lawnmower baselines at ``n_v = 4``), ``"b"``
        (pairwise, every stored fleet size, ascending), ``"c"`` (the receding-horizon planner at
        every fleet size where pairwise is stored too, drawn as the paired mass difference) or,
        when none applies, ``"all"`` (every group).
    """
    available = set(groups)
    panel_a = [(p, 4) for p in _PANEL_A_STYLES if (p, 4) in available]
    if not {("single", 4), ("pairwise", 4)} & available:
        panel_a = []  # the baselines alone are no panel (a)
    panel_b = sorted((g for g in available if g[0] == "pairwise"), key=lambda g: g[1])
    panel_c = sorted(
        (g for g in available if g[0] == "horizon" and ("pairwise", g[1]) in available),
        key=lambda g: g[1],
    )
    listed = (("a", panel_a), ("b", panel_b), ("c", panel_c))
    panels = [(name, keys) for name, keys in listed if keys]
    return panels or [("all", sorted(available))]


#: Line style and label of the ``n_v = 4`` curves of panel (a).
_PANEL_A_STYLES = {
    "single": ("--", "C1", "single-node"),
    "pairwise": ("-", "C0", "pairwise-node"),
    "horizon": ("-", "C3", "receding-horizon"),
    CLAIRVOYANT_LABEL: (":", "C2", "clairvoyant reference (knows the target)"),
    "random": (":", "C7", "random"),
    "lawnmower": ("-.", "C7", "lawnmower"),
}

_PANEL_TITLES = {
    "a": "(a) $n_v = 4$",
    "b": "(b) pairwise-node, varying fleet size",
    "c": "(c) receding-horizon minus pairwise-node (paired)",
    "all": "all stored runs",
}


def _draw_bounds(
    axes: Any, bounds: Mapping[int, np.ndarray], fleets: Sequence[int], black: bool
) -> None:
    """The mean clairvoyant Gaussian/Fisher estimate of each fleet size in ``fleets`` that
    ``bounds`` holds, dotted (black, or in the colour of the fleet's curve)."""
    for position, n_agents in enumerate(fleets):
        if n_agents in bounds:
            axes.plot(
                bounds[n_agents].mean(axis=0),
                linestyle=":",
                lw=1.0,
                color="k" if black else f"C{position % 10}",
                label=f"clairvoyant estimate, $n_v = {n_agents}$",
                gid=f"clairvoyant estimate, $n_v = {n_agents}$",
            )


def plot_fig1(
    records: Sequence[Trial],
    out_stem: str | os.PathLike[str],
    title: str = "",
    bounds: Mapping[int, np.ndarray] | None = None,
) -> list[Path]:
    """Draw Fig. 1 from ``records`` into ``out_stem.png`` and ``out_stem.svg``.

    Args:
        records: Trial records of one store.
        out_stem: Output path without suffix.
        title: Figure title (e.g. the environment and episode length).
        bounds: Fleet size -> ``(K, T + 1)`` clairvoyant mass bounds
            (:mod:`infoseek.experiments.bound`), drawn as their mean (thin dotted lines).

    Returns:
        The written paths.

    Raises:
        ValueError: No records.
    """
    figure = fig1_figure(records, title, bounds)
    stem = Path(out_stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_name(stem.name + ".png"), stem.with_name(stem.name + ".svg")]
    for path in paths:
        save_figure(figure, path, dpi=130)
    return paths


def save_figure(figure: Any, path: str | os.PathLike[str], dpi: int) -> None:
    """``figure.savefig`` with the same bytes for the same figure: an SVG gets no creation
    date and its element ids come from a fixed salt (matplotlib's defaults are the time and a
    random salt), so a redrawn committed figure changes only where its data do.

    Args:
        figure: A matplotlib figure.
        path: Output file; its suffix picks the format.
        dpi: Resolution of raster formats.
    """
    import matplotlib

    svg = Path(path).suffix.lower() == ".svg"
    with matplotlib.rc_context({"svg.hashsalt": "infoseek"}):
        figure.savefig(path, dpi=dpi, metadata={"Date": None} if svg else None)


def fig1_figure(
    records: Sequence[Trial],
    title: str = "",
    bounds: Mapping[int, np.ndarray] | None = None,
) -> Any:
    """The matplotlib ``Figure`` of Fig. 1 (arguments as :func:`plot_fig1`)."""
    from matplotlib.figure import Figure

    if not records:
        raise ValueError("nothing to plot: the results store has no finished trials")
    curves = mass_curves(records)
    radius = 1.0 if records[0].radius is None else float(records[0].radius)
    panels = fig1_panels(list(curves))
    figure = Figure(figsize=(6.6 * len(panels), 6.0), layout="constrained")
    for index, (panel, keys) in enumerate(panels):
        axes = figure.add_subplot(1, len(panels), index + 1)
        if panel == "c":
            _draw_paired_differences(axes, records, [n for _, n in keys], "pairwise", "horizon")
            continue
        for position, (planner, n_agents) in enumerate(keys):
            matrix = curves[planner, n_agents]
            bars = True
            offset = 0.12 * (position - (len(keys) - 1) / 2)
            count = f"({matrix.shape[0]} trials)"
            if panel == "a":
                style, color, name = _PANEL_A_STYLES[planner]
                label = f"{name} {count}"
                bars = planner in PANEL_A_BARS
                offset = 0.3 * (PANEL_A_BARS.index(planner) - 0.5) if bars else 0.0
            elif panel == "b":
                label, style, color = f"$n_v = {n_agents}$ {count}", "-", f"C{position % 10}"
            else:
                label = f"{planner}, $n_v = {n_agents}$ {count}"
                style, color = "-", f"C{position % 10}"
            _draw_group(axes, matrix, label, linestyle=style, color=color, offset=offset, bars=bars)
        if bounds is not None and panel in ("a", "b"):
            _draw_bounds(axes, bounds, sorted({n for _, n in keys}), black=panel == "a")
        _style(axes, _PANEL_TITLES[panel], radius)
    if title:
        figure.suptitle(title)
    return figure


def plot_fig1_from_store(
    directory: str | os.PathLike[str], out_stem: str | os.PathLike[str] | None = None
) -> list[Path]:
    """Fig. 1 of the results store in ``directory`` (default output ``directory/fig1``)."""
    manifest = read_manifest(directory)
    records = read_trials(directory)
    if not records:
        raise ValueError(f"nothing to plot: {directory} has no finished trials yet")
    config = manifest.get("config", {})
    settings = ", ".join(f"{k}={v}" for k, v in sorted(config.get("env_kwargs", {}).items()))
    env = str(config.get("env", "?")) + (f" with {settings}\n" if settings else ": ")
    title = f"{env}posterior mass within the localisation radius, {config.get('steps', '?')} steps"
    stem = Path(out_stem) if out_stem is not None else Path(directory) / "fig1"
    bounds = None
    if config.get("env") == "bearings_v0":
        from infoseek.experiments.bound import store_mass_bounds

        bounds = store_mass_bounds(records, config.get("env_kwargs", {}), int(config["steps"]))
    return plot_fig1(records, stem, title=title, bounds=bounds)
