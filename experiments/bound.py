r"""A clairvoyant upper bound on the posterior mass of bearings-only search (``bearings_v0``).

How far is every planner from the best possible? For trial ``k`` (target :math:`\theta^*`,
vehicles starting at :math:`c_i` with speed :math:`v`) the bound asks how much Fisher
information about :math:`\theta^*` *any* flight could have gathered by step ``t``, and how much
posterior mass that information allows within the localisation radius ``r``.

A bearing from position ``p`` at distance :math:`d = \|p - \theta^*\|` carries the Fisher
information :math:`n n^\top / (\sigma^2 d^2)` about the target position, ``n`` the unit normal
to the line of sight. Let ``e`` be the unit vector from :math:`\theta^*` to the centre
:math:`\bar c` of the starts, :math:`d_0 = \|\bar c - \theta^*\|`. After ``s`` steps vehicle
``i`` is inside the disk of radius :math:`R_i(s) = v s\,dt + \|c_i - \bar c\|` around
:math:`\bar c` (an airplane's chord never exceeds its arc). Every point of that disk is within
:math:`R` of the line through :math:`\theta^*` and :math:`\bar c` and at least :math:`d_0 - R`
from the target, so its bearing adds at most

.. math::  e^\top \Delta J e = \frac{(e \cdot n)^2}{\sigma^2 d^2} = \frac{(d \sin\alpha)^2}
    {\sigma^2 d^4} \le \frac{\min(R, d_0 - R)^2}{\sigma^2 (d_0 - R)^4}  \quad (R < d_0)

along ``e`` (no bound once the disk reaches the target). Summing over vehicles and steps
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
one). It is an upper limit under the stated assumption, not a curve any planner can reach.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import erf

from infoseek.experiments.bench import LOCALISED_MASS, make_env

FloatArray = NDArray[np.float64]

__all__ = ["mass_bound", "store_mass_bounds", "time_to_localise_bound"]


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
    gap = d0[:, None, None] - reach[None]  # (K, T, A): closest possible distance
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.minimum(reach[None], gap) ** 2 / (sigma**2 * gap**4)
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
    records: Sequence[Mapping[str, Any]], env_kwargs: Mapping[str, Any], steps: int
) -> dict[int, FloatArray]:
    """Fleet size -> ``(K, steps + 1)`` bounds of a ``bearings_v0`` store's trials (every trial
    of that fleet size once, in trial order), from the environments' start grid, speed, noise
    and radius.

    Raises:
        ValueError: The environment's sensor is not the bearing sensor.
    """
    truths: dict[int, dict[int, FloatArray]] = {}
    for record in records:
        truths.setdefault(int(record["n_agents"]), {})[int(record["trial"])] = np.asarray(
            record["truth"], dtype=np.float64
        )
    bounds = {}
    for n_agents, by_trial in sorted(truths.items()):
        env = make_env("bearings_v0", n_agents=n_agents, **env_kwargs)
        base = env.unwrapped
        if base.sensor.name != "bearing":
            raise ValueError(f"the bound needs the bearing sensor, got {base.sensor.name!r}")
        targets = np.stack([by_trial[k] for k in sorted(by_trial)])
        bounds[n_agents] = mass_bound(
            targets,
            np.asarray(base.start_positions, dtype=np.float64),
            float(base.vehicle.speed),
            float(base.dt),
            float(base.sensor.sigma),
            float(base.localization_radius),
            steps,
            float(base.space.volume),
        )
        env.close()
    return bounds


def describe(bounds: Mapping[int, FloatArray]) -> str:
    """One line per fleet size: the bound's mean time to localise and its mean mass curve."""
    lines = []
    for n_agents, matrix in sorted(bounds.items()):
        ttl = time_to_localise_bound(matrix)
        mean = matrix.mean(axis=0)
        marks = ", ".join(f"step {t}: {mean[t]:.3f}" for t in (5, 10, 15, 20) if t < mean.size)
        lines.append(
            f"  bound n_v = {n_agents}: mean ttl >= {ttl.mean():.2f} "
            f"(median {np.median(ttl):.0f}), mean mass <= {marks}"
        )
    return "\n".join(lines) if lines else "  bound: no trials"
