"""``infoseek claims DIR``: statistical tests of the paper's Fig. 1 claims on stored trials.

The paper (section IV.A, Fig. 1) makes two claims about bearings-only search:

* **A** (Fig. 1a): with ``n_v = 4`` vehicles the pairwise-node approximation localises faster
  than the single-node approximation;
* **B** (Fig. 1b): more vehicles localise faster (pairwise-node, ``n_v = 2, 3, 4, 10``).

Trial ``k`` of every group in a store faces the same target and start (its environment seed
depends only on the run's seed, the environment and ``k``; see
:mod:`infoseek.experiments.bench`), so groups are compared **paired by trial**. The response is
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
claimed direction. The command also prints the summary table of every group in the store.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from infoseek.experiments.arguments import check_results_directory
from infoseek.experiments.bench import format_summary, make_env, summarise, time_to_localise
from infoseek.experiments.bound import (
    bound_times,
    describe,
    headroom,
    store_mass_bounds,
    trials_beating_the_bound,
)
from infoseek.experiments.clairvoyant import CLAIRVOYANT_LABEL
from infoseek.experiments.plot import mass_curves, paired_masses
from infoseek.experiments.store import read_manifest, read_records


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


def times_to_localise(
    records: Sequence[Mapping[str, Any]], planner: str, n_agents: int, steps: int
) -> dict[int, float]:
    """``{trial: censored time to localise}`` of one group, checking the pairing by seed."""
    times = {}
    for record in records:
        if record["planner"] == planner and int(record["n_agents"]) == n_agents:
            ttl = time_to_localise(record["mass_agent0"])
            times[int(record["trial"])] = float(steps if ttl is None else ttl)
    return times


def paired_mass_gaps(
    records: Sequence[Mapping[str, Any]], base: str, other: str, n_agents: int, steps: int
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
    records: Sequence[Mapping[str, Any]], base: str, other: str, n_agents: int, steps: int
) -> str:
    """One line: the paired difference ``other - base`` of the mean posterior mass over steps
    ``0..steps`` (a low-variance summary of the whole curve) with a one-sided Wilcoxon test
    (``other`` higher)."""
    _, a, b = paired_masses(records, base, other, n_agents, steps)
    mean_a, mean_b = np.nanmean(a, axis=1), np.nanmean(b, axis=1)
    gap, se, p = wilcoxon_faster(mean_b, mean_a)  # "slower" = the larger mass here
    return (
        f"    mean posterior mass over steps 0-{steps}, {other} - {base}: {gap:+.4f} +- {se:.4f} "
        f"({100 * gap / float(mean_a.mean()):+.1f} % of {base}'s {mean_a.mean():.3f}), "
        f"one-sided Wilcoxon p {format_p_value(p)}"
    )


def _paired(groups: Sequence[dict[int, float]]) -> np.ndarray:
    """``(trials, groups)`` matrix over the trials every group has."""
    common = sorted(set.intersection(*(set(g) for g in groups)))
    return np.array([[g[t] for g in groups] for t in common], dtype=float).reshape(
        len(common), len(groups)
    )


def _check_pairing(records: Sequence[Mapping[str, Any]]) -> None:
    seeds: dict[int, int] = {}
    for record in records:
        trial, seed = int(record["trial"]), int(record["env_seed"])
        if seeds.setdefault(trial, seed) != seed:
            raise ValueError(
                f"trial {trial} has different environment seeds across groups: the store's "
                "groups are not paired"
            )


def format_p_value(p: float) -> str:
    """``"= 0.0123"``-style text of a p-value; one that underflowed to 0 prints as a bound.

    Args:
        p: The p-value.
    """
    if p <= 0.0:  # below the smallest normal double: say so instead of claiming p = 0
        return f"< {np.finfo(np.float64).tiny:.3g}"
    return f"= {p:.3g}"


def wilcoxon_faster(slower: np.ndarray, faster: np.ndarray) -> tuple[float, float, float]:
    """One-sided Wilcoxon signed-rank test that ``faster`` localises sooner than ``slower``.

    Returns:
        ``(mean difference slower - faster, its standard error, p-value)``.
    """
    difference = slower - faster
    stderr = float(np.std(difference, ddof=1) / np.sqrt(difference.size))
    if not np.any(difference != 0):
        return 0.0, stderr, 1.0
    result = stats.wilcoxon(slower, faster, alternative="greater", zero_method="wilcox")
    return float(np.mean(difference)), stderr, float(result.pvalue)


def _faster(
    records: Sequence[Mapping[str, Any]],
    slower: str,
    faster: str,
    n_agents: int,
    steps: int,
    alpha: float,
    label: str,
) -> str:
    """One line: paired test that planner ``faster`` localises sooner than ``slower``."""
    data = _paired(
        [
            times_to_localise(records, slower, n_agents, steps),
            times_to_localise(records, faster, n_agents, steps),
        ]
    )
    mean, stderr, p = wilcoxon_faster(data[:, 0], data[:, 1])
    verdict = "holds" if p < alpha else "not supported"
    relative = 100.0 * mean / float(np.mean(data[:, 0]))
    return (
        f"{label} (n_v = {n_agents}, {faster} faster than {slower}): {data.shape[0]} paired "
        f"trials, mean ttl {slower} - {faster} = {mean:+.2f} +- {stderr:.2f} steps "
        f"({relative:+.1f} % of {slower}'s {np.mean(data[:, 0]):.2f}), one-sided Wilcoxon "
        f"p {format_p_value(p)} -> {verdict} at alpha = {alpha}"
    )


BAND_STEPS = (5, 10, 15, 20)
"""Steps at which :func:`mass_bands` reports the Fig. 1 curves' means and quartile bands."""


def mass_bands(records: Sequence[Mapping[str, Any]], groups: Sequence[tuple[str, int]]) -> str:
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
        lines.append(f"    {planner}/{n_agents} mass mean (IQR): " + ", ".join(cells))
    return "\n".join(lines)


def baseline_lines(
    records: Sequence[Mapping[str, Any]],
    baseline: Sequence[Mapping[str, Any]],
    steps: int,
) -> list[str]:
    """Per group both stores hold: mean ttl here and in ``baseline`` over the trials both hold,
    the paired difference with its standard error and a two-sided Wilcoxon p-value."""
    lines = []
    ours = {(r["planner"], int(r["n_agents"])) for r in records}
    theirs = {(r["planner"], int(r["n_agents"])) for r in baseline}
    for planner, n_agents in sorted(ours & theirs, key=lambda g: (g[1], g[0])):
        new = times_to_localise(records, planner, n_agents, steps)
        old = times_to_localise(baseline, planner, n_agents, steps)
        trials = sorted(set(new) & set(old))
        a = np.array([new[k] for k in trials])
        b = np.array([old[k] for k in trials])
        difference = a - b
        stderr = float(np.std(difference, ddof=1) / np.sqrt(difference.size))
        p = 1.0 if not np.any(difference) else float(stats.wilcoxon(a, b).pvalue)
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
    records: Sequence[Mapping[str, Any]],
    steps: int,
    centres: Mapping[int, np.ndarray],
    bound: Mapping[int, Mapping[int, float]] | None = None,
) -> list[str]:
    """Per group: least-squares fit ``ttl = a d_0 + b`` of the time to localise against the
    target's initial distance ``d_0`` from the fleet's mean start position ``centres[n_v]``,
    with the correlation and the residual standard deviation; with ``bound`` (fleet size ->
    ``{trial: the bound's time to localise}``) the same fit of the bound per fleet size."""
    truths = {(int(r["n_agents"]), int(r["trial"])): r["truth"][:2] for r in records}
    series = {
        f"{planner}/{n_agents}": (n_agents, times_to_localise(records, planner, n_agents, steps))
        for planner, n_agents in sorted(
            {(r["planner"], int(r["n_agents"])) for r in records}, key=lambda g: g[::-1]
        )
    }
    for n_agents, times in sorted((bound or {}).items()):
        series[f"bound/{n_agents}"] = (n_agents, dict(times))
    lines = []
    for label, (n_agents, times) in series.items():
        trials = sorted(times)
        d = np.array(
            [np.linalg.norm(np.asarray(truths[n_agents, k]) - centres[n_agents]) for k in trials]
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


def _claim_b(
    records: Sequence[Mapping[str, Any]], sizes: Sequence[int], steps: int, alpha: float
) -> list[str]:
    """Claim B's lines: Page's trend test over the fleet sizes (three or more; with two, the
    one-sided Wilcoxon test decides) and the Wilcoxon test of each consecutive pair."""
    ordered = sorted(sizes, reverse=True)  # predicted: ttl increases as n_v decreases
    data = _paired([times_to_localise(records, "pairwise", n, steps) for n in ordered])
    means = ", ".join(f"n_v={n}: {m:.2f}" for n, m in zip(ordered, data.mean(axis=0), strict=True))
    head = f"Claim B (more vehicles localise faster, pairwise): {data.shape[0]} paired trials, "
    lines = []
    pairs = []
    for fewer, more in zip(sizes[:-1], sizes[1:], strict=True):
        pair = _paired(
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
        page = stats.page_trend_test(data)
        verdict = "holds" if page.pvalue < alpha else "not supported"
        test = f"Page's L = {page.statistic:.1f}, p {format_p_value(page.pvalue)}"
    else:
        verdict = "holds" if pairs[0] < alpha else "not supported"
        test = "two fleet sizes, decided by the one-sided Wilcoxon test below"
    return [f"{head}mean ttl {means}; {test} -> {verdict} at alpha = {alpha}", *lines]


def _print_bound(
    records: Sequence[Mapping[str, Any]], env_kwargs: Mapping[str, Any], steps: int
) -> dict[int, dict[int, float]]:
    """Print the clairvoyant bound's lines of a ``bearings_v0`` store; returns its times to
    localise (fleet size -> ``{trial: steps}``)."""
    bounds = store_mass_bounds(records, env_kwargs, steps)
    print("Clairvoyant bound (infoseek.experiments.bound; Gaussian-posterior assumption):")
    print(describe(bounds))
    print("What the bound leaves to gain over pairwise-node (mean time to localise):")
    print(headroom(records, bounds, steps))
    print("Trials localised before their own bound (where its assumption fails; r: radius):")
    print(trials_beating_the_bound(records, bounds, env_kwargs, steps))
    return bound_times(records, bounds)


def _read_baseline(
    args: argparse.Namespace, config: Mapping[str, Any]
) -> list[dict[str, Any]] | None:
    """The records of ``--baseline``, checked to pair with ``config`` (same env, seed, steps)."""
    if getattr(args, "baseline", None) is None:
        return None
    check_results_directory(args.baseline)
    other = read_manifest(args.baseline)["config"]
    mine = (config["env"], config["seed"], config["steps"])
    if (other["env"], other["seed"], other["steps"]) != mine:
        raise ValueError(
            f"--baseline {args.baseline}: env/seed/steps {other['env']}/{other['seed']}/"
            f"{other['steps']} differ from {mine[0]}/{mine[1]}/{mine[2]}: not paired"
        )
    return read_records(args.baseline)


def _print_paper_claims(
    records: Sequence[Mapping[str, Any]],
    groups: set[tuple[str, int]],
    steps: int,
    alpha: float,
) -> None:
    """Claim A (pairwise-node faster than single-node at n_v = 4, and at the other fleet sizes
    both ran) and Claim B (more vehicles localise faster)."""
    if {("single", 4), ("pairwise", 4)} <= groups:
        print(_faster(records, "single", "pairwise", 4, steps, alpha, "Claim A"))
        print(mean_mass_line(records, "single", "pairwise", 4, steps))
        print(mass_bands(records, [("single", 4), ("pairwise", 4)]))
    else:
        print("Claim A: needs groups single/4 and pairwise/4")
    for n in sorted(n for planner, n in groups if planner == "single" and n != 4):
        if ("pairwise", n) in groups:
            print(_faster(records, "single", "pairwise", n, steps, alpha, "  also"))
    sizes = sorted(n for planner, n in groups if planner == "pairwise")
    if len(sizes) >= 2:
        print("\n".join(_claim_b(records, sizes, steps, alpha)))
    else:
        print("Claim B: needs pairwise groups with at least two fleet sizes")


def run_claims(args: argparse.Namespace) -> int:
    """Print the summary table and the tests of claims A and B; returns the exit code."""
    if not 0.0 < args.alpha < 1.0:
        raise ValueError(f"--alpha must be in (0, 1), got {args.alpha}")
    if args.trials is not None and args.trials < 1:
        raise ValueError(f"--trials must be a positive number of trials, got {args.trials}")
    manifest = read_manifest(args.directory)
    check_results_directory(args.directory)
    records = read_records(args.directory)
    if args.trials is not None:
        records = [r for r in records if int(r["trial"]) < args.trials]
    if not records:
        raise ValueError(f"{args.directory}: the store holds no trials")
    steps = int(manifest["config"]["steps"])
    _check_pairing(records)
    baseline = _read_baseline(args, manifest["config"])
    print(format_summary(summarise(records, steps), steps))
    print()
    groups = {(r["planner"], int(r["n_agents"])) for r in records}
    _print_paper_claims(records, groups, steps, args.alpha)
    for n in sorted(n for planner, n in groups if planner == "horizon"):
        if ("pairwise", n) in groups:
            print(_faster(records, "pairwise", "horizon", n, steps, args.alpha, "Horizon"))
            print(paired_mass_gaps(records, "pairwise", "horizon", n, steps))
    for n in sorted(n for planner, n in groups if planner == CLAIRVOYANT_LABEL):
        if ("pairwise", n) in groups:
            line = _faster(records, "pairwise", CLAIRVOYANT_LABEL, n, steps, args.alpha, "")
            print("Clairvoyant reference (knows the target)" + line)
    bound = None
    if manifest["config"].get("env") == "bearings_v0" and all("truth" in r for r in records):
        bound = _print_bound(records, manifest["config"].get("env_kwargs", {}), steps)
    if all("truth" in r for r in records):
        config = manifest["config"]
        fleets = {int(r["n_agents"]) for r in records}
        env_kwargs = config.get("env_kwargs", {})
        centres = {n: start_centre(config["env"], env_kwargs, n) for n in fleets}
        print(
            "Time to localise against the target's initial distance d0 from the fleet's mean "
            "start position:"
        )
        print("\n".join(distance_lines(records, steps, centres, bound)))
    if baseline is not None:
        print(f"Against the baseline {args.baseline} (same seeds):")
        print("\n".join(baseline_lines(records, baseline, steps)))
    return 0
