r"""A clairvoyant Gaussian/Fisher estimate of the best posterior mass of bearings-only search.

The module keeps its historical name (``bound``), but what it computes is an *estimate* under a
Gaussian-posterior assumption, not a bound that the exact posterior obeys (last paragraph).

How far is every planner from the best possible? For trial ``k`` (target :math:`\theta^*`,
vehicles starting at :math:`c_i` with speed :math:`v`) the bound asks how much Fisher
information about :math:`\theta^*` *any* flight could have gathered by step ``t``, and how much
posterior mass that information allows within the localisation radius ``r``.

A bearing from position ``p`` at distance :math:`d = \|p - \theta^*\|` carries the Fisher
information :math:`n n^\top / (\sigma^2 d^2)` about the target position, ``n`` the unit normal
to the line of sight. Let ``e`` be the unit vector from :math:`\theta^*` to the centre
:math:`\bar c` of the starts, :math:`d_0 = \|\bar c - \theta^*\|`. After ``s`` steps vehicle
``i`` is inside the disk of radius :math:`R_i(s) = v s\,dt + \|c_i - \bar c\|` around
:math:`\bar c` (an airplane's chord never exceeds its arc). With the target at the origin and
``e`` the first axis, a point :math:`p = (x, y)` adds :math:`e^\top \Delta J e = (e \cdot n)^2 /
(\sigma^2 d^2) = y^2 / (\sigma^2 (x^2 + y^2)^2)` along ``e``. Moving ``p`` towards the target
along its line of sight keeps the angle and shrinks ``d``, so the maximum over the disk lies on
its near boundary :math:`p = (d_0 + R\cos\varphi, R\sin\varphi)`, where the term is
:math:`R^2 (1 - c^2) / (\sigma^2 (A + B c)^2)` with :math:`c = \cos\varphi`,
:math:`A = d_0^2 + R^2`, :math:`B = 2 d_0 R`. The term vanishes at :math:`c = \pm 1`
and its derivative in ``c`` only at :math:`c = -B / A`, which gives the exact maximum

.. math::  \max_{\|p - \bar c\| \le R} e^\top \Delta J e = \frac{R^2}{\sigma^2 (d_0^2 - R^2)^2}
    \quad (R < d_0)

(no bound once the disk reaches the target). Summing over vehicles and steps
``1..t`` bounds :math:`e^\top J_t e`. **Assumption**: the belief after ``t`` steps is Gaussian
with covariance no smaller than :math:`J_t^{-1}` (the Cramer-Rao / efficient large-sample
limit; the uniform prior and the bounded domain are ignored). Then the variance along ``e`` is at
least :math:`1 / e^\top J_t e` (Cauchy-Schwarz) and the mass of *any* disk of radius ``r``
(Anderson's inequality: the centred one holds the most) is at most

.. math::  m_t \le \operatorname{erf}\big(r \sqrt{e^\top J_t e / 2}\big).

The earliest ``t`` at which this reaches the localisation mass (0.9) bounds the time to
localise from below. Before the first bearing (step 0) the belief is the uniform prior, whose
disk mass :math:`\pi r^2 / |\text{domain}|` the bound never goes below. The bound is loose: it
ignores the turn-rate limit, lets every vehicle be at the best point of its disk at every step,
and keeps only the direction along which the team's early bearings are weakest (the radial
one). It is an upper limit only under the stated assumption, and **the assumption does not
hold**: the uniform prior on a bounded domain cuts a belief whose target lies near an edge, and
a posterior after a few bearings is not Gaussian; an exact grid posterior on the same bearings
can be sharper than the Fisher information allows, and stored trials localise before their own
estimate (:func:`trials_beating_the_bound` counts them; the grid-posterior results page
measures the exact posterior against it). So it is reported as an estimate of how fast
clairvoyant flight could localise, not as a limit that no planner can beat.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import erf

from infoseek.experiments.analysis import LOCALISED_MASS, Trial, time_to_localise
from infoseek.experiments.environments import make_env

FloatArray = NDArray[np.float64]

__all__ = [
    "bound_report",
    "bound_times",
    "describe",
    "headroom",
    "mass_bound",
    "store_mass_bounds",
    "time_to_localise_bound",
    "trials_beating_the_bound",
]


def mass_bound(
    targets: FloatArray,
    starts: FloatArray,
    speed: float,
    dt: float,
    sigma: float,
    radius: float,
    steps: int,
    area: float,
) -> FloatArray:
    """``(K, steps + 1)`` bound on the posterior mass within ``radius`` after ``0..steps`` steps
    (never below the uniform prior's mass ``pi r^2 / area`` of a disk).

    Args:
        targets: ``(K, >= 2)`` true targets of ``K`` trials (position first).
        starts: ``(A, 2)`` start positions of the vehicles.
        speed: Vehicle speed (distance per unit time).
        dt: Time step.
        sigma: Bearing noise standard deviation (rad).
        radius: Localisation radius.
        steps: Episode length.
        area: Area of the search domain (the uniform prior's support).
    """
    starts = np.asarray(starts, dtype=np.float64)
    centre = starts.mean(axis=0)
    offsets = np.linalg.norm(starts - centre, axis=1)  # (A,)
    d0 = np.linalg.norm(np.asarray(targets, dtype=np.float64)[:, :2] - centre, axis=1)  # (K,)
    s = np.arange(1, steps + 1)
    reach = speed * dt * s[:, None] + offsets[None, :]  # (T, A)
    reach_sq = reach[None] ** 2  # (1, T, A)
    gap = d0[:, None, None] ** 2 - reach_sq  # (K, T, A): d0^2 - R^2, > 0 while outside
    with np.errstate(divide="ignore", invalid="ignore"):
        per = reach_sq / (sigma**2 * gap**2)
    per = np.where(gap > 0.0, per, np.inf)
    info = np.cumsum(per.sum(axis=2), axis=1)  # (K, T): bound on e^T J_t e
    bound = np.concatenate([np.zeros((d0.size, 1)), erf(radius * np.sqrt(info / 2.0))], axis=1)
    return np.maximum(bound, math.pi * radius**2 / area)


def time_to_localise_bound(bounds: FloatArray, threshold: float = LOCALISED_MASS) -> FloatArray:
    """``(K,)`` first step at which each trial's bound reaches ``threshold`` (censored at the
    last step + 1 if it never does)."""
    reached = bounds >= threshold
    first = np.argmax(reached, axis=1).astype(np.float64)
    first[~reached.any(axis=1)] = bounds.shape[1]
    return first


def store_mass_bounds(
    records: Sequence[Trial], env_kwargs: Mapping[str, Any], steps: int
) -> dict[int, FloatArray]:
    """Fleet size -> ``(K, steps + 1)`` bounds of a ``bearings_v0`` store's trials (every trial
    of that fleet size once, in trial order), from the environments' start grid, speed, noise
    and radius.

    Raises:
        ValueError: The environment's sensor is not the bearing sensor.
    """
    truths: dict[int, dict[int, FloatArray]] = {}
    for record in records:
        truths.setdefault(record.n_agents, {})[record.trial] = np.asarray(
            record.truth, dtype=np.float64
        )
    bounds = {}
    for n_agents, by_trial in sorted(truths.items()):
        env = make_env("bearings_v0", n_agents=n_agents, **env_kwargs)
        config = env.unwrapped.config
        env.close()
        if config.sensor.name != "bearing":
            raise ValueError(f"the bound needs the bearing sensor, got {config.sensor.name!r}")
        targets = np.stack([by_trial[k] for k in sorted(by_trial)])
        bounds[n_agents] = mass_bound(
            targets,
            np.asarray(config.start_positions, dtype=np.float64),
            float(config.vehicle.speed),
            float(config.dt),
            float(config.sensor.sigma),
            float(config.localization_radius),
            steps,
            float(config.space.volume),
        )
    return bounds


def describe(bounds: Mapping[int, FloatArray]) -> str:
    """One line per fleet size: the estimate's mean time to localise and its mean mass curve."""
    lines = []
    for n_agents, matrix in sorted(bounds.items()):
        ttl = time_to_localise_bound(matrix)
        mean = matrix.mean(axis=0)
        marks = ", ".join(f"step {t}: {mean[t]:.3f}" for t in (5, 10, 15, 20) if t < mean.size)
        lines.append(
            f"  estimate n_v = {n_agents}: mean ttl {ttl.mean():.2f} "
            f"(median {np.median(ttl):.0f})" + (f", mean mass {marks}" if marks else "")
        )
    return "\n".join(lines) if lines else "  estimate: no trials"


def bound_report(
    records: Sequence[Trial], env_kwargs: Mapping[str, Any], steps: int
) -> tuple[list[str], dict[int, dict[int, float]]]:
    """The bound's section of ``infoseek claims`` on a ``bearings_v0`` store: the bound by
    fleet size, the headroom it leaves pairwise-node and the trials that beat it; and its times
    to localise (fleet size -> ``{trial: steps}``)."""
    bounds = store_mass_bounds(records, env_kwargs, steps)
    lines = [
        "Clairvoyant Gaussian/Fisher estimate (infoseek.experiments.bound; an estimate, not a "
        "bound: trials beat it, below):",
        describe(bounds),
        "What the estimate leaves to gain over pairwise-node (mean time to localise):",
        headroom(records, bounds, steps),
        "Trials localised before their own estimate (where its Gaussian assumption fails; "
        "r: radius):",
        trials_beating_the_bound(records, bounds, env_kwargs, steps),
    ]
    return lines, bound_times(records, bounds)


def bound_rows(records: Sequence[Trial]) -> dict[int, dict[int, int]]:
    """Fleet size -> ``{trial: its row in that fleet size's}`` :func:`store_mass_bounds` matrix
    (every trial of a fleet size once, in trial order)."""
    trials: dict[int, set[int]] = {}
    for record in records:
        trials.setdefault(record.n_agents, set()).add(record.trial)
    return {n: {trial: row for row, trial in enumerate(sorted(t))} for n, t in trials.items()}


def bound_times(
    records: Sequence[Trial], bounds: Mapping[int, FloatArray]
) -> dict[int, dict[int, float]]:
    """Fleet size -> ``{trial: the bound's time to localise}``."""
    times = {}
    for n_agents, rows in bound_rows(records).items():
        first = time_to_localise_bound(bounds[n_agents])
        times[n_agents] = {trial: float(first[row]) for trial, row in rows.items()}
    return times


def headroom(
    records: Sequence[Trial],
    bounds: Mapping[int, FloatArray],
    steps: int,
    reference: str = "pairwise",
) -> str:
    """One line per fleet size of the ``reference`` planner: its mean time to localise, the
    estimate's over the same trials, and the relative reduction that reaching the estimate
    would give, ``1 - estimate / reference`` (a limit only under the estimate's assumption,
    which fails: module docstring)."""
    limits = bound_times(records, bounds)
    times: dict[int, list[tuple[float, float]]] = {}
    for record in records:
        if record.planner == reference:
            n_agents, ttl = record.n_agents, time_to_localise(record.mass_agent0)
            times.setdefault(n_agents, []).append(
                (steps if ttl is None else ttl, limits[n_agents][record.trial])
            )
    lines = []
    for n_agents, pairs in sorted(times.items()):
        mean, limit = np.asarray(pairs, dtype=np.float64).mean(axis=0)
        lines.append(
            f"  {reference}/{n_agents}: mean ttl {mean:.2f}, estimate {limit:.2f} over the same "
            f"{len(pairs)} trials: {100 * (1 - limit / mean):.1f} % faster at the estimate"
        )
    return "\n".join(lines)


def trials_beating_the_bound(
    records: Sequence[Trial],
    bounds: Mapping[int, FloatArray],
    env_kwargs: Mapping[str, Any],
    steps: int,
) -> str:
    """One line per stored group: how many trials localise (agent 0's mass, as in the summary
    table) *before* their own bound; by how many steps on average over all the group's trials
    (what beating the bound takes off the mean time to localise); how many of those have their
    target within the localisation radius ``r`` of the domain's edge (with that number among
    all the group's trials: the bound's Gaussian assumption leaves out the prior's support);
    and how many localised with agent 0's estimate more than ``r`` from the target (a belief
    concentrated in the wrong place, which no information bound covers).

    Args:
        records: Stored trials of a ``bearings_v0`` store (with ``truth``).
        bounds: :func:`store_mass_bounds` of the same records.
        env_kwargs: The store's environment options (domain and localisation radius).
        steps: Episode length (never-localised trials are censored there).
    """
    limits = bound_times(records, bounds)
    domains, radius = _domains(sorted(limits), env_kwargs)
    groups: dict[tuple[str, int], list[tuple[float, bool, bool]]] = {}
    for record in records:
        low, high = domains[record.n_agents]
        ttl = time_to_localise(record.mass_agent0)
        truth = np.asarray(record.truth, dtype=np.float64)[:2]
        edge = float(np.min(np.concatenate([truth - low, high - truth])))
        limit = limits[record.n_agents][record.trial]
        ahead = 0.0 if ttl is None else max(limit - ttl, 0.0)
        wrong = ahead > 0 and float(_at(record.error_agent0, ttl)) > radius
        groups.setdefault((record.planner, record.n_agents), []).append(
            (ahead, edge <= radius, wrong)
        )
    lines = []
    for (planner, n_agents), flags in sorted(groups.items()):
        early = [(near, wrong) for ahead, near, wrong in flags if ahead > 0]
        lines.append(
            f"  {planner}/{n_agents}: {len(early)} of {len(flags)} trials, "
            f"{sum(ahead for ahead, _, _ in flags) / len(flags):.2f} steps ahead per trial; "
            f"{sum(n for n, _ in early)} with the target within r of the edge "
            f"({sum(near for _, near, _ in flags)} of all trials), {sum(w for _, w in early)} "
            f"with the estimate more than r from the target"
        )
    return "\n".join(lines)


def _at(series: Any, step: int | None) -> float:
    """``series[step]`` (a series the store lacks, or no step, reads as NaN)."""
    if series is None or step is None or series[step] is None:
        return math.nan
    return float(series[step])


def _domains(
    fleets: Sequence[int], env_kwargs: Mapping[str, Any]
) -> tuple[dict[int, tuple[FloatArray, FloatArray]], float]:
    """Fleet size -> the domain's ``(low, high)`` corners, and the localisation radius, of the
    ``bearings_v0`` environments of a store."""
    domains = {}
    radius = math.nan
    for n_agents in fleets:
        env = make_env("bearings_v0", n_agents=n_agents, **env_kwargs)
        config = env.unwrapped.config
        env.close()
        domains[n_agents] = (config.space.low_array[:2], config.space.high_array[:2])
        radius = float(config.localization_radius)
    return domains, radius
