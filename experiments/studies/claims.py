"""``infoseek claims DIR``: statistical tests of the paper's Fig. 1 claims on stored trials.

The paper (section IV.A, Fig. 1) makes two claims about bearings-only search:

* **A** (Fig. 1a): with ``n_v = 4`` vehicles the pairwise-node approximation localises faster
  than the single-node approximation;
* **B** (Fig. 1b): more vehicles localise faster (pairwise-node, ``n_v = 2, 3, 4, 10``).

Trial ``k`` of every group in a store faces the same target and start (its environment seed
depends only on the run's seed, the environment and ``k``; see
:mod:`infoseek.experiments.seeds`), so groups are compared **paired by trial**. The response is
the time to localise: the first step at which agent 0's posterior mass within the localisation
radius of its MMSE estimate reaches 0.9 (the Fig. 1 metric), censored at the episode length.

* Claim A: one-sided Wilcoxon signed-rank test of ``ttl(single) - ttl(pairwise) > 0``
  (``scipy.stats.wilcoxon``, zero differences dropped), with the mean paired difference and
  its standard error; the same test is reported for every other fleet size that has both
  groups.
* Claim B: Page's L test for an ordered alternative (``scipy.stats.page_trend_test``), trials as
  blocks and fleet sizes as treatments, predicting time to localise decreasing in ``n_v``; and
  one-sided Wilcoxon tests between consecutive fleet sizes.

A claim "holds" at level ``alpha`` when its test rejects the null of no difference in the
claimed direction. The command also prints the summary table of every group in the store, the
receding-horizon planner and the clairvoyant reference against pairwise-node where the store
holds them, the clairvoyant bound of a ``bearings_v0`` store (:mod:`infoseek.experiments.bound`)
and the linear fit of the time to localise against the target's initial distance.
:func:`claims_report` returns the sections (the results pages quote them), :func:`run_claims`
prints them. The store is read column by column (:mod:`infoseek.experiments.columns`).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from infoseek.experiments.analysis import (
    Trial,
    check_pairing,
    format_p_value,
    format_summary,
    groups_of,
    mass_curves,
    paired_masses,
    paired_matrix,
    summarise,
    times_to_localise,
    wilcoxon_faster,
    wilcoxon_two_sided,
)
from infoseek.experiments.arguments import check_results_directory
from infoseek.experiments.bound import bound_report
from infoseek.experiments.clairvoyant import CLAIRVOYANT_LABEL
from infoseek.experiments.columns import read_trials
from infoseek.experiments.environments import make_env
from infoseek.experiments.store import read_manifest

__all__ = [
    "BAND_STEPS",
    "ClaimsReport",
    "add_claims_arguments",
    "claims_report",
    "distance_lines",
    "mass_bands",
    "run_claims",
    "start_centre",
]

BAND_STEPS = (5, 10, 15, 20)
"""Steps at which :func:`mass_bands` reports the Fig. 1 curves' means and quartile bands."""


def add_claims_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek claims``."""
    parser.add_argument("directory", type=Path, help="results directory of a bench/reproduce run")
    parser.add_argument("--alpha", type=float, default=0.05, help="significance level (0.05)")
    parser.add_argument(
        "--baseline",
        type=Path,
        default=None,
        help="another store with the same seeds (e.g. before a code change): paired "
        "differences of every group both hold",
    )
    parser.add_argument(
        "--trials",
        type=int,
        default=None,
        help="use only trials 0..N-1 of every group (default: all stored trials)",
    )


# ----------------------------------------------------------------------------------- lines
def paired_mass_gaps(
    records: Sequence[Trial], base: str, other: str, n_agents: int, steps: int
) -> str:
    """One line: the mean paired mass difference ``other - base`` at :data:`BAND_STEPS` and 30,
    with standard errors, over the trials both groups hold (where in the search one wins)."""
    common, a, b = paired_masses(records, base, other, n_agents, steps)
    difference = b - a
    cells = []
    for step in (t for t in (*BAND_STEPS, 30) if t <= steps):
        column = difference[:, step]
        se = column.std(ddof=1) / np.sqrt(column.size) if column.size > 1 else float("nan")
        cells.append(f"step {step}: {column.mean():+.3f} +- {se:.3f}")
    return f"    {other} - {base} paired mass, {len(common)} trials: " + ", ".join(cells)


def mean_mass_line(
    records: Sequence[Trial], base: str, other: str, n_agents: int, steps: int
) -> str:
    """One line: the paired difference ``other - base`` of the mean posterior mass over steps
    ``0..steps`` (a low-variance summary of the whole curve) with a one-sided Wilcoxon test
    (``other`` higher)."""
    _, a, b = paired_masses(records, base, other, n_agents, steps)
    mean_a, mean_b = np.nanmean(a, axis=1), np.nanmean(b, axis=1)
    gap, se, p = wilcoxon_faster(mean_b, mean_a)  # "slower" = the larger mass here
    base_mean = float(mean_a.mean())
    relative = f"{100 * gap / base_mean:+.1f} %" if base_mean > 0 else "no relative change"
    return (
        f"    mean posterior mass over steps 0-{steps}, {other} - {base}: {gap:+.4f} +- {se:.4f} "
        f"({relative} of {base}'s {base_mean:.3f}), one-sided Wilcoxon p {format_p_value(p)}"
    )


def faster_line(
    records: Sequence[Trial],
    slower: str,
    faster: str,
    n_agents: int,
    steps: int,
    alpha: float,
    label: str,
) -> str:
    """One line: paired test that planner ``faster`` localises sooner than ``slower``."""
    data = paired_matrix(
        [
            times_to_localise(records, slower, n_agents, steps),
            times_to_localise(records, faster, n_agents, steps),
        ]
    )
    mean, stderr, p = wilcoxon_faster(data[:, 0], data[:, 1])
    verdict = "holds" if p < alpha else "not supported"
    base = float(np.mean(data[:, 0]))
    relative = f"{100.0 * mean / base:+.1f} %" if base > 0 else "no relative change"
    return (
        f"{label} (n_v = {n_agents}, {faster} faster than {slower}): {data.shape[0]} paired "
        f"trials, mean ttl {slower} - {faster} = {mean:+.2f} +- {stderr:.2f} steps "
        f"({relative} of {slower}'s {base:.2f}), one-sided Wilcoxon "
        f"p {format_p_value(p)} -> {verdict} at alpha = {alpha}"
    )


def mass_bands(records: Sequence[Trial], groups: Sequence[tuple[str, int]]) -> str:
    """One line per group: mean and interquartile range of agent 0's posterior mass at the
    steps of :data:`BAND_STEPS` (the numbers behind the Fig. 1 curves and quartile bars).

    Args:
        records: Trial records.
        groups: ``(planner, n_agents)`` groups to report, in order.
    """
    curves = mass_curves(records)
    lines = []
    for planner, n_agents in groups:
        matrix = curves[(planner, n_agents)]
        cells = []
        for step in (t for t in BAND_STEPS if t < matrix.shape[1]):
            q25, q75 = np.nanpercentile(matrix[:, step], [25, 75])
            cells.append(f"step {step}: {np.nanmean(matrix[:, step]):.3f} ({q75 - q25:.3f})")
        if cells:  # an episode shorter than the first band step has none
            lines.append(f"    {planner}/{n_agents} mass mean (IQR): " + ", ".join(cells))
    return "\n".join(lines)


def baseline_lines(records: Sequence[Trial], baseline: Sequence[Trial], steps: int) -> list[str]:
    """Per group both stores hold: mean ttl here and in ``baseline`` over the trials both hold,
    the paired difference with its standard error and a two-sided Wilcoxon p-value."""
    lines = []
    for planner, n_agents in sorted(
        groups_of(records) & groups_of(baseline), key=lambda g: (g[1], g[0])
    ):
        new = times_to_localise(records, planner, n_agents, steps)
        old = times_to_localise(baseline, planner, n_agents, steps)
        trials = sorted(set(new) & set(old))
        if len(trials) < MIN_PAIRED_TRIALS:
            lines.append(
                f"  {planner}/{n_agents}: needs at least {MIN_PAIRED_TRIALS} trials both stores "
                f"hold, has {len(trials)}"
            )
            continue
        a = np.array([new[k] for k in trials])
        b = np.array([old[k] for k in trials])
        difference = a - b
        stderr = float(np.std(difference, ddof=1) / np.sqrt(difference.size))
        p = wilcoxon_two_sided(a, b)
        lines.append(
            f"  {planner}/{n_agents}: {len(trials)} paired trials, mean ttl {a.mean():.2f} "
            f"(baseline {b.mean():.2f}), difference {difference.mean():+.2f} +- {stderr:.2f} "
            f"steps, two-sided Wilcoxon p {format_p_value(p)}"
        )
    return lines


def start_centre(env: str, env_kwargs: Mapping[str, Any], n_agents: int) -> np.ndarray:
    """``(2,)`` mean start position of ``n_agents`` vehicles in ``env`` built with
    ``env_kwargs`` (the start grid depends on the fleet size and spacing)."""
    built = make_env(env, n_agents=n_agents, **env_kwargs)
    try:
        return np.asarray(built.unwrapped.config.start_positions, float).mean(axis=0)
    finally:
        built.close()


def distance_lines(
    records: Sequence[Trial],
    steps: int,
    centres: Mapping[int, np.ndarray],
    bound: Mapping[int, Mapping[int, float]] | None = None,
) -> list[str]:
    """Per group: least-squares fit ``ttl = a d_0 + b`` of the time to localise against the
    target's initial distance ``d_0`` from the fleet's mean start position ``centres[n_v]``,
    with the correlation and the residual standard deviation; with ``bound`` (fleet size ->
    ``{trial: the bound's time to localise}``) the same fit of the bound per fleet size."""
    truths = {(r.n_agents, r.trial): r.truth for r in records}
    series = {
        f"{planner}/{n_agents}": (n_agents, times_to_localise(records, planner, n_agents, steps))
        for planner, n_agents in sorted(groups_of(records), key=lambda g: g[::-1])
    }
    for n_agents, times in sorted((bound or {}).items()):
        series[f"bound/{n_agents}"] = (n_agents, dict(times))
    lines = []
    for label, (n_agents, times) in series.items():
        trials = sorted(times)
        d = np.array(
            [
                np.linalg.norm(np.asarray(truths[n_agents, k])[:2] - centres[n_agents])
                for k in trials
            ]
        )
        y = np.array([times[k] for k in trials])
        if d.size < 3 or np.ptp(d) == 0.0:
            continue
        slope, intercept = np.polyfit(d, y, 1)
        residual = y - (slope * d + intercept)
        lines.append(
            f"  {label}: ttl = {slope:.2f} d0 {intercept:+.2f} (correlation "
            f"{np.corrcoef(d, y)[0, 1]:.2f}, residual sd {residual.std(ddof=2):.2f} steps)"
        )
    return lines


def claim_b_lines(
    records: Sequence[Trial], sizes: Sequence[int], steps: int, alpha: float
) -> list[str]:
    """Claim B's lines: Page's trend test over the fleet sizes (three or more; with two, the
    one-sided Wilcoxon test decides) and the Wilcoxon test of each consecutive pair."""
    ordered = sorted(sizes, reverse=True)  # predicted: ttl increases as n_v decreases
    data = paired_matrix([times_to_localise(records, "pairwise", n, steps) for n in ordered])
    means = ", ".join(f"n_v={n}: {m:.2f}" for n, m in zip(ordered, data.mean(axis=0), strict=True))
    head = f"Claim B (more vehicles localise faster, pairwise): {data.shape[0]} paired trials, "
    lines = []
    pairs = []
    for fewer, more in zip(sizes[:-1], sizes[1:], strict=True):
        pair = paired_matrix(
            [
                times_to_localise(records, "pairwise", fewer, steps),
                times_to_localise(records, "pairwise", more, steps),
            ]
        )
        mean, stderr, p = wilcoxon_faster(pair[:, 0], pair[:, 1])
        pairs.append(p)
        lines.append(
            f"  n_v = {more} vs {fewer}: mean ttl difference {mean:+.2f} +- {stderr:.2f} "
            f"steps, one-sided Wilcoxon p {format_p_value(p)}"
        )
    if len(sizes) >= 3:
        from scipy import stats  # imported here: slow to import (infoseek.experiments.analysis)

        page = stats.page_trend_test(data)
        verdict = "holds" if page.pvalue < alpha else "not supported"
        test = f"Page's L = {page.statistic:.1f}, p {format_p_value(page.pvalue)}"
    else:
        verdict = "holds" if pairs[0] < alpha else "not supported"
        test = "two fleet sizes, decided by the one-sided Wilcoxon test below"
    return [f"{head}mean ttl {means}; {test} -> {verdict} at alpha = {alpha}", *lines]


def paired_trials(records: Sequence[Trial], groups: Sequence[tuple[str, int]]) -> int:
    """How many trial indices every one of ``groups`` holds (the pairs a paired test gets)."""
    held = [{r.trial for r in records if (r.planner, r.n_agents) == group} for group in groups]
    return len(set.intersection(*held)) if held else 0


#: Fewest paired trials a paired test is run on (a standard error needs two).
MIN_PAIRED_TRIALS = 2


def paper_claim_lines(records: Sequence[Trial], steps: int, alpha: float) -> list[str]:
    """Claim A (pairwise-node faster than single-node at n_v = 4, and at the other fleet sizes
    both ran) and Claim B (more vehicles localise faster); a claim whose groups share fewer
    than :data:`MIN_PAIRED_TRIALS` trials says so instead of a test."""
    groups = groups_of(records)
    lines = []
    claim_a = [("single", 4), ("pairwise", 4)]
    if set(claim_a) <= groups and paired_trials(records, claim_a) < MIN_PAIRED_TRIALS:
        lines.append(
            f"Claim A: needs at least {MIN_PAIRED_TRIALS} paired trials of single/4 and "
            f"pairwise/4, has {paired_trials(records, claim_a)}"
        )
    elif set(claim_a) <= groups:
        lines.append(faster_line(records, "single", "pairwise", 4, steps, alpha, "Claim A"))
        lines.append(mean_mass_line(records, "single", "pairwise", 4, steps))
        lines.append(mass_bands(records, [("single", 4), ("pairwise", 4)]))
    else:
        lines.append("Claim A: needs groups single/4 and pairwise/4")
    for n in sorted(n for planner, n in groups if planner == "single" and n != 4):
        pair = [("single", n), ("pairwise", n)]
        if ("pairwise", n) in groups and paired_trials(records, pair) >= MIN_PAIRED_TRIALS:
            lines.append(faster_line(records, "single", "pairwise", n, steps, alpha, "  also"))
    sizes = sorted(n for planner, n in groups if planner == "pairwise")
    claim_b = [("pairwise", n) for n in sizes]
    if len(sizes) >= 2 and paired_trials(records, claim_b) < MIN_PAIRED_TRIALS:
        lines.append(
            f"Claim B: needs at least {MIN_PAIRED_TRIALS} paired trials of every pairwise group, "
            f"has {paired_trials(records, claim_b)}"
        )
    elif len(sizes) >= 2:
        lines.append("\n".join(claim_b_lines(records, sizes, steps, alpha)))
    else:
        lines.append("Claim B: needs pairwise groups with at least two fleet sizes")
    return lines


def reference_lines(records: Sequence[Trial], steps: int, alpha: float) -> tuple[list[str], ...]:
    """The receding-horizon planner's lines and the clairvoyant reference's, each against
    pairwise-node at every fleet size where the store holds both."""
    groups = groups_of(records)
    horizon, clairvoyant = [], []
    for n in sorted(n for planner, n in groups if planner == "horizon"):
        if ("pairwise", n) in groups:
            horizon.append(faster_line(records, "pairwise", "horizon", n, steps, alpha, "Horizon"))
            horizon.append(paired_mass_gaps(records, "pairwise", "horizon", n, steps))
    for n in sorted(n for planner, n in groups if planner == CLAIRVOYANT_LABEL):
        if ("pairwise", n) in groups:
            line = faster_line(records, "pairwise", CLAIRVOYANT_LABEL, n, steps, alpha, "")
            clairvoyant.append("Clairvoyant reference (knows the target)" + line)
    return horizon, clairvoyant


# ---------------------------------------------------------------------------------- report
@dataclass(frozen=True)
class ClaimsReport:
    """The sections of ``infoseek claims``, each a list of printed lines.

    Attributes:
        summary: The summary table of every group (one text block).
        claims: Claims A and B.
        horizon: Receding horizon against pairwise-node.
        clairvoyant: The clairvoyant reference against pairwise-node.
        bound: The clairvoyant bound (``bearings_v0`` stores).
        distance: The fits of time to localise against the initial distance (with its title).
        baseline: Paired differences against a baseline store (with its title).
    """

    summary: str
    claims: list[str]
    horizon: list[str] = field(default_factory=list)
    clairvoyant: list[str] = field(default_factory=list)
    bound: list[str] = field(default_factory=list)
    distance: list[str] = field(default_factory=list)
    baseline: list[str] = field(default_factory=list)

    def text(self) -> str:
        """Everything, as ``infoseek claims`` prints it."""
        sections = (self.claims, self.horizon, self.clairvoyant, self.bound, self.distance)
        lines = [self.summary, "", *(line for section in sections for line in section)]
        return "\n".join([*lines, *self.baseline])


def claims_report(
    directory: str | os.PathLike[str],
    alpha: float = 0.05,
    trials: int | None = None,
    baseline: str | os.PathLike[str] | None = None,
) -> ClaimsReport:
    """The report of ``infoseek claims`` on the store in ``directory`` (module docstring).

    Args:
        directory: The store.
        alpha: Significance level.
        trials: Use only trials ``0..trials-1`` of every group.
        baseline: Another store with the same environment, seed and episode length.

    Raises:
        ValueError: Bad ``alpha`` or ``trials``, an empty or unpaired store, an unpaired
            baseline.
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"--alpha must be in (0, 1), got {alpha}")
    if trials is not None and trials < 1:
        raise ValueError(f"--trials must be a positive number of trials, got {trials}")
    config = read_manifest(directory)["config"]
    check_results_directory(Path(directory))
    records = read_trials(directory)
    if trials is not None:
        records = [r for r in records if r.trial < trials]
    if not records:
        raise ValueError(f"{directory}: the store holds no trials")
    steps = int(config["steps"])
    check_pairing(records)
    others = None if baseline is None else _read_baseline(Path(baseline), config)
    horizon, clairvoyant = reference_lines(records, steps, alpha)
    bound_lines, bound, distance = _geometry_lines(records, config, steps)
    return ClaimsReport(
        summary=format_summary(summarise(records, steps), steps),
        claims=paper_claim_lines(records, steps, alpha),
        horizon=horizon,
        clairvoyant=clairvoyant,
        bound=bound_lines,
        distance=distance,
        baseline=[]
        if others is None
        else [
            f"Against the baseline {baseline} (same seeds):",
            "\n".join(baseline_lines(records, others, steps)),
        ],
    )


def _geometry_lines(
    records: Sequence[Trial], config: Mapping[str, Any], steps: int
) -> tuple[list[str], dict[int, dict[int, float]] | None, list[str]]:
    """The bound's lines and times (a ``bearings_v0`` store with true targets) and the
    distance fits (any store with true targets)."""
    if any(r.truth is None for r in records):
        return [], None, []
    env_kwargs = config.get("env_kwargs", {})
    bound_lines: list[str] = []
    bound = None
    if config.get("env") == "bearings_v0":
        bound_lines, bound = bound_report(records, env_kwargs, steps)
    fleets = {r.n_agents for r in records}
    centres = {n: start_centre(config["env"], env_kwargs, n) for n in fleets}
    title = (
        "Time to localise against the target's initial distance d0 from the fleet's mean "
        "start position:"
    )
    return bound_lines, bound, [title, "\n".join(distance_lines(records, steps, centres, bound))]


def _read_baseline(path: Path, config: Mapping[str, Any]) -> list[Any]:
    """The trials of the store ``path``, checked to pair with ``config`` (same env, seed,
    steps)."""
    check_results_directory(path)
    other = read_manifest(path)["config"]
    mine = (config["env"], config["seed"], config["steps"])
    if (other["env"], other["seed"], other["steps"]) != mine:
        raise ValueError(
            f"--baseline {path}: env/seed/steps {other['env']}/{other['seed']}/"
            f"{other['steps']} differ from {mine[0]}/{mine[1]}/{mine[2]}: not paired"
        )
    return read_trials(path)


def run_claims(args: argparse.Namespace) -> int:
    """``infoseek claims DIR``: print :func:`claims_report`; returns the exit code."""
    report = claims_report(args.directory, args.alpha, args.trials, args.baseline)
    print(report.text())
    return 0
