"""``infoseek reproduce ablation``: how the pairwise-node gain over single-node (Claim A) depends on
the settings the paper does not state.

Around ``bearings_v0``'s defaults one setting is varied at a time: the bearing noise ``sigma``
(0.05, 0.1, 0.2, 0.3 rad), the airplane speed (1, 2 units/s, turn rate 0.5 rad/s kept), the start
spacing (1.5 = tight, 2 = default, 6 = spread), the particles per belief (500, 2000, 8000) and
the fleet size (2, 4, 10). Every setting is a resumable benchmark store ``OUT/<name>/store`` of
paired single/pairwise trials (trial ``k`` of every store and group faces the same target:
the environment seed depends only on the root seed and ``k``), so the settings are paired with
each other as well.

Two responses per trial, both of agent 0's belief as in Fig. 1:

* the **mean posterior mass** within the localisation radius over steps ``0..T`` (a low-variance
  summary of the whole Fig. 1 curve, ``T`` the episode length);
* the **time to localise** (first step with mass >= 0.9, censored at ``T``).

The default setting's store also holds two treatments at ``n_v = 4``, the switched planners
of :mod:`infoseek.experiments.decisions` (pairwise-node for the first 1 or 5 steps, then
single-node), each compared with single-node like pairwise-node is: they show which decisions
make the gain.

For each setting, fleet size and treatment the table gives single's mean, the mean paired
difference treatment - single with its standard error, the difference relative to single's mean
and a one-sided Wilcoxon signed-rank p-value (treatment better), and the **gap curve**: the mean
paired mass difference at every step, which shows when in the search the gain is made.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from infoseek.experiments.analysis import (
    Trial,
    paired_masses,
    times_to_localise,
    wilcoxon_faster,
)
from infoseek.experiments.bench import BenchPlan
from infoseek.experiments.columns import read_trials
from infoseek.experiments.decisions import SWITCHED_PLANNERS
from infoseek.experiments.environments import default_steps
from infoseek.experiments.plot import save_figure
from infoseek.experiments.store import read_manifest

ABLATION_ENV = "bearings_v0"
DEFAULT_TRIALS = 100
GAP_STEPS = (2, 5, 10, 20, 30)
"""Steps at which the table reports the gap curve."""


@dataclass(frozen=True)
class AblationSetting:
    """One varied setting.

    Attributes:
        name: Directory of its store under the output directory.
        factor: The setting varied.
        value: Its value, as printed.
        env_kwargs: ``bearings_v0`` keyword arguments that realise it.
        fleets: Fleet sizes with a single/pairwise pair of groups.
        treatments: Further ``(planner label, n_agents)`` groups, each compared with single-node
            at its fleet size.
    """

    name: str
    factor: str
    value: str
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    fleets: tuple[int, ...] = (4,)
    treatments: tuple[tuple[str, int], ...] = ()


SETTINGS: tuple[AblationSetting, ...] = (
    AblationSetting(
        "default",
        "defaults",
        "sigma 0.1, speed 1, spacing 2, N 2000",
        {},
        (2, 4, 10),
        tuple((label, 4) for label in SWITCHED_PLANNERS),
    ),
    AblationSetting("sigma_0.05", "sigma (rad)", "0.05", {"sensor_kwargs": {"sigma": 0.05}}),
    AblationSetting("sigma_0.2", "sigma (rad)", "0.2", {"sensor_kwargs": {"sigma": 0.2}}),
    AblationSetting("sigma_0.3", "sigma (rad)", "0.3", {"sensor_kwargs": {"sigma": 0.3}}),
    AblationSetting(
        "speed_2", "speed", "2", {"vehicle_kwargs": {"speed": 2.0, "max_turn_rate": 0.5}}
    ),
    AblationSetting("spacing_1.5", "start spacing", "1.5 (tight)", {"start_spacing": 1.5}),
    AblationSetting("spacing_6", "start spacing", "6 (spread)", {"start_spacing": 6.0}),
    AblationSetting("particles_500", "particles", "500", {"n_particles": 500}),
    AblationSetting("particles_8000", "particles", "8000", {"n_particles": 8000}),
)


def ablation_plans(
    trials: int = DEFAULT_TRIALS,
    seed: int = 0,
    steps: int | None = None,
    settings: Sequence[AblationSetting] = SETTINGS,
) -> Iterator[tuple[str, BenchPlan]]:
    """``(store name, plan)`` of every setting, in order.

    Args:
        trials: Paired trials per group.
        seed: Root seed.
        steps: Episode length (default: the environment's, 60).
        settings: The settings (default :data:`SETTINGS`).
    """
    for setting in settings:
        groups = [(planner, n) for n in setting.fleets for planner in ("single", "pairwise")]
        groups += list(setting.treatments)
        yield (
            setting.name,
            BenchPlan(
                env=ABLATION_ENV,
                env_kwargs=dict(setting.env_kwargs),
                steps=default_steps(ABLATION_ENV, setting.env_kwargs) if steps is None else steps,
                seed=seed,
                groups=groups,
                trials=trials,
            ),
        )


@dataclass(frozen=True)
class GapRow:
    """Pairwise (or another treatment) - single at one setting and fleet size (paired by trial).

    Attributes:
        setting, factor, value: The :class:`AblationSetting`.
        planner: The treatment's planner label (``"pairwise"`` or one of the setting's
            ``treatments``).
        n_agents: Fleet size.
        trials: Paired trials.
        mass_single: Single's mean of the per-trial mean posterior mass.
        mass_gap, mass_gap_se, mass_p: Mean paired difference, its standard error, one-sided
            Wilcoxon p-value (pairwise higher).
        ttl_single: Single's mean time to localise (censored).
        ttl_gap, ttl_gap_se, ttl_p: Mean paired difference single - pairwise (positive:
            pairwise faster), its standard error, one-sided Wilcoxon p-value.
        gap_curve, gap_curve_se: ``(T + 1,)`` mean paired mass difference at each step and its
            standard error.
    """

    setting: str
    factor: str
    value: str
    planner: str
    n_agents: int
    trials: int
    mass_single: float
    mass_gap: float
    mass_gap_se: float
    mass_p: float
    ttl_single: float
    ttl_gap: float
    ttl_gap_se: float
    ttl_p: float
    gap_curve: list[float]
    gap_curve_se: list[float]

    @property
    def mass_gap_percent(self) -> float:
        """``mass_gap`` relative to ``mass_single``, in percent."""
        return 100.0 * self.mass_gap / self.mass_single

    @property
    def label(self) -> str:
        """Short name of the row: its setting, or its treatment where that is not pairwise."""
        if self.planner != "pairwise":
            return SWITCHED_PLANNERS.get(self.planner, self.planner)
        return "defaults" if self.factor == "defaults" else f"{self.factor} = {self.value}"


def gap_row(
    setting: AblationSetting,
    records: Sequence[Trial],
    steps: int,
    n_agents: int,
    planner: str = "pairwise",
) -> GapRow:
    """The :class:`GapRow` of ``planner`` against single-node in one setting's store at one fleet
    size (the trials both groups hold)."""
    trials, s, p = paired_masses(records, "single", planner, n_agents, steps)
    if len(trials) < 2:
        raise ValueError(
            f"{setting.name}: fewer than 2 paired trials of {planner} at n_v = {n_agents}"
        )
    mass_s, mass_p = s.mean(axis=1), p.mean(axis=1)
    gap, gap_se, gap_p = wilcoxon_faster(mass_p, mass_s)  # "slower" = the larger mass here
    single_ttl = times_to_localise(records, "single", n_agents, steps)
    pairwise_ttl = times_to_localise(records, planner, n_agents, steps)
    ttl_s = np.array([single_ttl[k] for k in trials])
    ttl_p = np.array([pairwise_ttl[k] for k in trials])
    ttl_gap, ttl_se, ttl_pvalue = wilcoxon_faster(ttl_s, ttl_p)
    difference = p - s
    return GapRow(
        setting=setting.name,
        factor=setting.factor,
        value=setting.value,
        planner=planner,
        n_agents=n_agents,
        trials=len(trials),
        mass_single=float(mass_s.mean()),
        mass_gap=gap,
        mass_gap_se=gap_se,
        mass_p=gap_p,
        ttl_single=float(ttl_s.mean()),
        ttl_gap=ttl_gap,
        ttl_gap_se=ttl_se,
        ttl_p=ttl_pvalue,
        gap_curve=difference.mean(axis=0).tolist(),
        gap_curve_se=(difference.std(axis=0, ddof=1) / math.sqrt(len(trials))).tolist(),
    )


def ablation_rows(out: str | Path, settings: Sequence[AblationSetting] = SETTINGS) -> list[GapRow]:
    """Every setting's rows from the stores under ``out`` (settings without a store skipped)."""
    rows = []
    for setting in settings:
        store = Path(out) / setting.name / "store"
        if not (store / "manifest.json").exists():
            continue
        steps = int(read_manifest(store)["config"]["steps"])
        records = read_trials(store)
        for n_agents in setting.fleets:
            rows.append(gap_row(setting, records, steps, n_agents))
        for planner, n_agents in setting.treatments:
            rows.append(gap_row(setting, records, steps, n_agents, planner))
    return rows


def format_table(rows: Sequence[GapRow]) -> str:
    """Markdown table of the rows (mass gap in percent of single's mass, ttl gap in steps)."""
    head = (
        "| setting | value | planner | n_v | trials | mass single | mass gap (pl - s) | rel. | p | "
        "ttl single | ttl gain (s - pl) | p | gap at steps "
        + ", ".join(str(t) for t in GAP_STEPS)
        + " |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    )
    lines = [head]
    for r in rows:
        curve = ", ".join(f"{r.gap_curve[t]:+.3f}" for t in GAP_STEPS if t < len(r.gap_curve))
        lines.append(
            f"| {r.factor} | {r.value} | {SWITCHED_PLANNERS.get(r.planner, r.planner)} | "
            f"{r.n_agents} | {r.trials} | {r.mass_single:.3f} | "
            f"{r.mass_gap:+.4f} +- {r.mass_gap_se:.4f} | {r.mass_gap_percent:+.1f} % | "
            f"{r.mass_p:.2g} | {r.ttl_single:.2f} | {r.ttl_gap:+.2f} +- {r.ttl_gap_se:.2f} | "
            f"{r.ttl_p:.2g} | {curve} |"
        )
    return "\n".join(lines)


def write_results(out: str | Path, rows: Sequence[GapRow]) -> list[Path]:
    """``OUT/ablation.md``, ``OUT/ablation.json`` and the figure ``OUT/ablation.png/.svg``."""
    out = Path(out)
    table = out / "ablation.md"
    table.write_text(format_table(rows) + "\n")
    data = out / "ablation.json"
    data.write_text(json.dumps([asdict(r) for r in rows], indent=1) + "\n")
    return [table, data, *plot_ablation(rows, out / "ablation")]


#: Legend entry of the gap curves' standard-error bands.
SE_LABEL = "band: +- 1 standard error of the paired mean"


def plot_ablation(rows: Sequence[GapRow], stem: Path) -> list[Path]:
    """(a) the mean-mass gap of every row with its 95 % interval; (b) the gap of the
    ``n_v = 4`` pairwise rows by setting and step, as a colour map (one row per setting: nine
    noisy curves on one axes could not be told apart); (c) the gap curves of the treatments at
    ``n_v = 4`` beside pairwise-node in their setting, with one standard error shaded. Every
    drawn artist carries a ``gid`` naming the legend entry or colour bar that explains it."""
    figure = ablation_figure(rows)
    paths = []
    for suffix in (".png", ".svg"):
        path = stem.with_suffix(suffix)
        save_figure(figure, path, dpi=110)
        paths.append(path)
    return paths


def ablation_figure(rows: Sequence[GapRow]) -> Any:
    """The matplotlib ``Figure`` of :func:`plot_ablation`."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(17, 5.6), layout="constrained")
    bars, heat, treated = figure.subplots(1, 3, width_ratios=(1, 1.15, 1.05))
    _draw_gap_intervals(bars, rows)
    _draw_gap_map(figure, heat, [r for r in rows if r.n_agents == 4 and r.planner == "pairwise"])
    treated_settings = {r.setting for r in rows if r.planner != "pairwise" and r.n_agents == 4}
    for r in rows:
        if r.n_agents == 4 and r.setting in treated_settings:
            _gap_curve(treated, r, r.label if r.planner != "pairwise" else "pairwise throughout")
    treated.axhline(0.0, color="0.5", linewidth=0.8, gid="frame")
    treated.set_xlabel("step")
    treated.set_ylabel("mean paired mass gap to single")
    treated.set_title("(c) pairwise only at first (n_v = 4)")
    if treated.lines[1:]:
        from matplotlib.patches import Patch

        handles, labels = treated.get_legend_handles_labels()
        band = Patch(facecolor="0.5", alpha=0.2)
        treated.legend([*handles, band], [*labels, SE_LABEL], fontsize=8)
    return figure


def _draw_gap_intervals(axes: Any, rows: Sequence[GapRow]) -> None:
    """Panel (a): every row's mean-mass gap (% of single's) with its 95 % interval."""
    labels = [f"{r.label}, n_v = {r.n_agents}" for r in rows]
    y = np.arange(len(rows))[::-1]
    gaps = np.array([r.mass_gap_percent for r in rows])
    half = np.array([196.0 * r.mass_gap_se / r.mass_single for r in rows])
    label = "mean gap (dot) and its 95 % interval (bar)"
    container = axes.errorbar(gaps, y, xerr=half, fmt="o", capsize=3, label=label)
    for artist in container.get_children():
        artist.set_gid(label)
    axes.axvline(0.0, color="0.5", linewidth=0.8, gid="frame")
    axes.set_yticks(y, labels, fontsize=9)
    axes.set_xlabel("mean posterior mass over the episode, minus single's (% of single)")
    axes.set_ylim(-1.3, len(rows) - 0.5)  # a free row at the bottom for the legend
    axes.set_title("(a) gain over single-node by setting")
    axes.legend(loc="lower right", fontsize=8)


def _draw_gap_map(figure: Any, axes: Any, rows: Sequence[GapRow]) -> None:
    """Panel (b): the mean paired mass gap of each setting (rows) at each step (columns)."""
    from matplotlib.colors import TwoSlopeNorm

    if not rows:
        axes.set_axis_off()
        return
    length = max(len(r.gap_curve) for r in rows)
    gaps = np.full((len(rows), length), np.nan)
    for k, row in enumerate(rows):
        gaps[k, : len(row.gap_curve)] = row.gap_curve
    limit = float(np.nanmax(np.abs(gaps))) or 1.0
    label = "mean paired mass gap, pairwise - single"
    image = axes.imshow(
        gaps,
        aspect="auto",
        cmap="RdBu_r",
        norm=TwoSlopeNorm(vcenter=0.0, vmin=-limit, vmax=limit),
        interpolation="nearest",
        extent=(-0.5, length - 0.5, len(rows) - 0.5, -0.5),
        gid=label,
    )
    axes.set_yticks(np.arange(len(rows)), [r.label for r in rows], fontsize=9)
    axes.set_xlabel("step")
    axes.set_title("(b) when the gain is made (pairwise, n_v = 4)")
    colour_bar = figure.colorbar(image, ax=axes, fraction=0.05, pad=0.02)
    colour_bar.set_label(label)


def _gap_curve(axes: Any, row: GapRow, label: str) -> None:
    curve = np.array(row.gap_curve)
    steps = np.arange(curve.size)
    (line,) = axes.plot(steps, curve, label=label, lw=1.6, gid=label)
    se = np.array(row.gap_curve_se)
    axes.fill_between(
        steps, curve - se, curve + se, alpha=0.2, color=line.get_color(), lw=0, gid=SE_LABEL
    )
