"""The clairvoyant mass bound: its inequalities against brute force, and the stored curves."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from scipy.special import erf

from infoseek.experiments.analysis import masses_by_trial
from infoseek.experiments.bound import (
    bound_rows,
    headroom,
    mass_bound,
    store_mass_bounds,
    time_to_localise_bound,
    trials_beating_the_bound,
)
from infoseek.experiments.columns import TrialView, read_trials

FIG1_STORE = Path(__file__).resolve().parents[1] / "experiments" / "results" / "fig1" / "store"


def test_per_step_term_is_the_maximum_over_the_reachable_disk() -> None:
    """Brute force: e^T (n n^T / (sigma^2 d^2)) e at 20,000 points inside the disk and 20,000
    on its boundary never exceeds the bound's per-step term R^2 / (sigma^2 (d0^2 - R^2)^2) (one
    vehicle at the centre: the bound's first increment), and the boundary attains it."""
    rng = np.random.default_rng(0)
    sigma = 0.1
    for _ in range(20):
        target = rng.uniform(10, 40, 2)
        centre = rng.uniform(0, 10, 2)
        d0 = np.linalg.norm(target - centre)
        reach = rng.uniform(0.05, 0.95) * d0
        e = (centre - target) / d0
        angle = rng.uniform(0, 2 * np.pi, 40_000)
        rad = reach * np.concatenate([np.sqrt(rng.uniform(0, 1, 20_000)), np.ones(20_000)])
        points = centre + np.stack([rad * np.cos(angle), rad * np.sin(angle)], axis=1)
        los = points - target
        d = np.linalg.norm(los, axis=1)
        normal = np.stack([-los[:, 1], los[:, 0]], axis=1) / d[:, None]
        brute = (normal @ e) ** 2 / (sigma**2 * d**2)
        bound = mass_bound(target[None], centre[None], reach, 1.0, sigma, 1.0, 1, 1600.0)
        term = reach**2 / (sigma**2 * (d0**2 - reach**2) ** 2)
        assert brute.max() <= term * (1 + 1e-12)
        assert brute.max() >= term * (1 - 1e-3)
        assert bound[0, 1] == pytest.approx(max(erf(np.sqrt(term / 2.0)), np.pi / 1600.0))


def test_gaussian_disk_mass_never_exceeds_the_directional_bound() -> None:
    """Monte Carlo: a Gaussian with covariance J^-1 puts at most erf(r sqrt(e^T J e / 2)) in
    any disk of radius r, for every unit e (Cauchy-Schwarz + Anderson)."""
    rng = np.random.default_rng(1)
    for _ in range(20):
        a = rng.normal(size=(2, 2))
        information = a @ a.T * rng.uniform(0.5, 20) + 0.01 * np.eye(2)
        samples = rng.multivariate_normal(np.zeros(2), np.linalg.inv(information), 40_000)
        centre = rng.normal(scale=0.3, size=2)
        mass = np.mean(np.linalg.norm(samples - centre, axis=1) <= 1.0)
        e = rng.normal(size=2)
        e /= np.linalg.norm(e)
        assert mass <= erf(np.sqrt(e @ information @ e / 2.0)) + 0.01


def test_time_to_localise_bound_is_the_first_crossing() -> None:
    bounds = np.array([[0.0, 0.5, 0.95, 0.99], [0.0, 0.1, 0.2, 0.3]])
    np.testing.assert_array_equal(time_to_localise_bound(bounds), [2.0, 4.0])


def _trial(
    trial: int, truth: Sequence[float], mass: Sequence[float], error: Sequence[float]
) -> TrialView:
    """A stored pairwise-node trial at ``n_v = 4`` with these series."""
    return TrialView(
        planner="pairwise",
        n_agents=4,
        trial=trial,
        env_seed=trial,
        radius=1.0,
        truth=np.array(truth),
        mass_agent0=np.array(mass),
        error_agent0=np.array(error),
        plan_time=np.zeros(len(mass) - 1),
    )


def test_trials_beating_their_bound_and_the_headroom_left() -> None:
    """Two hand-made trials against hand-made bounds (first crossings at steps 5 and 2): trial 0
    localises at step 3, two steps early, with its target 0.5 from the domain's edge and its
    estimate 1.5 off; trial 1 localises at step 4, after its bound, in the middle."""
    records = [
        _trial(0, [39.5, 20.0], [0.0, 0.2, 0.5, 0.95], [20.0, 5.0, 2.0, 1.5]),
        _trial(1, [20.0, 20.0], [0.0, 0.2, 0.5, 0.6, 0.91], [20.0, 5.0, 2.0, 1.0, 0.2]),
    ]
    ramp = np.array([[0.0, 0.1, 0.2, 0.3, 0.4, 0.95], [0.0, 0.5, 0.95, 0.96, 0.97, 0.98]])
    assert trials_beating_the_bound(records, {4: ramp}, {}, 60) == (
        "  pairwise/4: 1 of 2 trials, 1.00 steps ahead per trial; 1 with the target within r "
        "of the edge (1 of all trials), 1 with the estimate more than r from the target"
    )
    # headroom pairs each trial with its own bound row: single-node ran trial 1 alone (ttl 4,
    # bound 2)
    records.append(dataclasses.replace(records[1], planner="single"))
    assert headroom(records, {4: ramp}, 60, reference="single") == (
        "  single/4: mean ttl 4.00, estimate 2.00 over the same 1 trials: 50.0 % faster at the "
        "estimate"
    )


def test_no_stored_fig1_curve_crosses_the_bound() -> None:
    """Each stored group's mean mass curve against the mean bound of the same trials (the
    receding-horizon groups hold a prefix of the trials). A belief of N equally weighted
    particles cannot hold less than 1/N outside the disk: it reports 1.0 where the bound is
    1 - 3e-8, so the curve may exceed the bound by at most 1/N."""
    records = read_trials(FIG1_STORE)
    bounds = store_mass_bounds(records, {}, 60)
    rows = bound_rows(records)
    groups = {(record.planner, record.n_agents) for record in records}
    assert {n for _, n in groups} == set(bounds)
    resolution = 1.0 / 2000  # bearings_v0's default n_particles, which the store ran with
    for planner, n_agents in sorted(groups):
        masses = masses_by_trial(records, planner, n_agents, 61)
        trials = sorted(masses)
        mean_curve = np.nanmean([masses[k] for k in trials], axis=0)
        limit = bounds[n_agents][[rows[n_agents][k] for k in trials]].mean(axis=0)
        # step 0 is the uniform prior: its sampled disk mass scatters around pi / 1600
        assert mean_curve[0] == pytest.approx(limit[0], abs=2e-4)
        assert np.all(mean_curve[1:] <= limit[1:] + resolution), (planner, n_agents)
