"""The exact grid posterior (infoseek.envs.grid_posterior) against independent computations:
a single bearing's wedge-shaped posterior in closed form (1-D integrals in polar coordinates
around the sensor), importance sampling of the particle filter without resampling (its weights
give the Monte Carlo standard error), and bad input; the grid-posterior study
(``infoseek reproduce grid_posterior``) against the Fig. 1 store it reruns, and its page."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import integrate, stats

from infoseek.envs import make
from infoseek.envs.grid_posterior import GridPosterior
from infoseek.envs.sensors.bearing import BearingSensor
from infoseek.experiments.analysis import time_to_localise
from infoseek.experiments.cli import main
from infoseek.experiments.columns import read_trials
from infoseek.experiments.pages.registry import PAGES, render_page
from infoseek.experiments.studies.grid_posterior import read_results

SIGMA = 0.1
POSE = np.array([12.0, 15.0])
BEARING = 0.7
SIDE = 40.0


def wrapped_normal(residual: np.ndarray | float) -> np.ndarray:
    """The wrapped-normal density, written here from its image sum (not the sensor's code)."""
    r = np.asarray(residual, dtype=float)
    r = (r + math.pi) % (2 * math.pi) - math.pi
    return sum(stats.norm.pdf(r + 2 * math.pi * k, scale=SIGMA) for k in range(-3, 4))


def reach(phi: float) -> float:
    """Distance from POSE to the edge of the box [0, SIDE)^2 along direction phi."""
    u = np.array([math.cos(phi), math.sin(phi)])
    steps = [(SIDE - POSE[i]) / u[i] if u[i] > 0 else -POSE[i] / u[i] for i in (0, 1) if u[i] != 0]
    return float(min(steps))


def polar(f: object, order: int) -> float:
    """``int f(phi) * reach(phi)^order / order dphi`` over the likelihood's support (the wedge
    is negligible beyond 12 sigma of the bearing)."""
    return integrate.quad(
        lambda phi: wrapped_normal(BEARING - phi) * f(phi) * reach(phi) ** order / order,  # type: ignore[operator]
        BEARING - 12 * SIGMA,
        BEARING + 12 * SIGMA,
        limit=200,
        epsabs=0,
        epsrel=1e-10,
    )[0]


def one_bearing(cells: int = 400) -> GridPosterior:
    grid = GridPosterior((0.0, 0.0), (SIDE, SIDE), cells=cells)
    grid.update(BearingSensor(SIGMA), POSE[None], [[BEARING]], np.array([True]))
    return grid


def test_one_bearing_matches_the_closed_form_wedge() -> None:
    """Posterior after one bearing from POSE: p(theta) = f(z - phi(theta)) / Z on the box, so
    in polar coordinates around POSE, Z = int f rho^2 / 2, the mean is POSE + int f rho^3/3 u /
    Z and the entropy is -int (rho^2 / 2) (f / Z) log(f / Z); the grid's midpoint rule
    (h = 0.1) is within its O(h^2) error of them."""
    grid = one_bearing()
    z = polar(lambda phi: 1.0, 2)
    mean = POSE + np.array(
        [polar(math.cos, 3) / z, polar(math.sin, 3) / z]
    )  # int f rho^3/3 (cos, sin)
    entropy = -polar(lambda phi: math.log(wrapped_normal(BEARING - phi) / z) / z, 2)
    np.testing.assert_allclose(grid.mmse(), mean, atol=2e-3)
    assert grid.entropy() == pytest.approx(entropy, abs=5e-3)


def test_disk_mass_of_one_bearing_matches_quadrature_and_converges() -> None:
    """The mass of a disk across the wedge, by Gauss-Legendre x trapezoid quadrature in polar
    coordinates around the disk's centre (normalised by the closed-form Z), against the grid
    at h = 0.1 and h = 0.05: within 0.2 % (the module's O(h^2) error), and closer on the
    finer grid."""
    centre = POSE + 8.0 * np.array([math.cos(BEARING + 0.05), math.sin(BEARING + 0.05)])
    radius = 1.0
    nodes, weights = np.polynomial.legendre.leggauss(200)
    rho = 0.5 * radius * (nodes + 1.0)
    alpha = np.linspace(0.0, 2 * math.pi, 800, endpoint=False)
    x = centre[0] + rho[:, None] * np.cos(alpha)[None, :]
    y = centre[1] + rho[:, None] * np.sin(alpha)[None, :]
    density = wrapped_normal(BEARING - np.arctan2(y - POSE[1], x - POSE[0]))
    inner = (density * rho[:, None]).sum(axis=1) * (2 * math.pi / alpha.size)
    mass = 0.5 * radius * float(weights @ inner) / polar(lambda phi: 1.0, 2)
    assert 0.01 < mass < 0.03  # the wedge runs 30 units to the edge: a small share here
    coarse = one_bearing(400).mass_within(radius, centre)
    fine = one_bearing(800).mass_within(radius, centre)
    assert coarse == pytest.approx(mass, rel=2e-3)
    assert abs(fine - mass) < abs(coarse - mass)


def test_mass_within_a_uniform_density_is_the_disk_area() -> None:
    """At the prior the density is 1 / 1600: a disk inside the box holds pi r^2 / 1600, to the
    sub-cell sampling's accuracy (module docstring), wherever it sits on the cells."""
    grid = GridPosterior((0.0, 0.0), (SIDE, SIDE))
    for centre, radius in (((20.0, 20.0), 1.0), ((7.33, 11.71), 1.0), ((30.02, 8.5), 2.5)):
        expected = math.pi * radius**2 / SIDE**2
        assert grid.mass_within(radius, centre) == pytest.approx(expected, rel=1e-3)
    assert grid.entropy() == pytest.approx(math.log(SIDE**2), abs=1e-9)
    np.testing.assert_allclose(grid.mmse(), [20.0, 20.0], atol=1e-9)


def test_matches_importance_sampling_of_the_filter_within_its_monte_carlo_error() -> None:
    """bearings_v0 with 4 agents and 20000 particles, never resampled: the filter is then
    self-normalised importance sampling from the uniform prior with the same likelihood, so its
    mass within r of its MMSE and its MMSE have the delta-method standard errors
    sqrt(sum w_i^2 (g_i - g)^2) from its own weights. Every step of 12, the grid's mass of the
    same disk and the grid's MMSE lie within 4 standard errors (plus the grid's discretisation
    error, 2e-3)."""
    env = make("bearings_v0", n_agents=4, n_particles=20000, resample_threshold=0.0)
    env.reset(seed=3)
    unwrapped = env.unwrapped
    config = unwrapped.config
    grid = GridPosterior.from_config(config)
    for t in range(12):
        env.step({a: np.array([0.3 * math.sin(0.2 * t + i)]) for i, a in enumerate(env.agents)})
        poses = config.vehicle.position(unwrapped.vehicle_states)
        grid.update(
            config.filter_sensor, poses, unwrapped.last_measurements, unwrapped.last_reception[0]
        )
        view = unwrapped.belief("vehicle_0")
        w = np.asarray(view.weights) / np.sum(view.weights)
        particles = np.asarray(view.particles)
        estimate = w @ particles
        inside = np.hypot(*(particles - estimate).T) <= config.localization_radius
        mass = float(w[inside].sum())
        mass_se = math.sqrt(float(w**2 @ (inside - mass) ** 2))
        mean_se = np.sqrt(w**2 @ (particles - estimate) ** 2)
        assert 1.0 / float(w @ w) > 30  # enough effective samples for the delta method
        grid_mass = grid.mass_within(config.localization_radius, estimate)
        assert abs(grid_mass - mass) <= 4 * mass_se + 2e-3, t
        assert np.all(np.abs(grid.mmse() - estimate) <= 4 * mean_se + 2e-3), t
    env.close()


def test_pruning_changes_nothing_visible() -> None:
    """Cells 700 nats below the mode underflow anyway: the pruned grid reads the same."""
    full, pruned = (GridPosterior((0.0, 0.0), (SIDE, SIDE), prune=p) for p in (None, 700.0))
    sensor = BearingSensor(SIGMA)
    rng = np.random.default_rng(1)
    target = np.array([22.0, 9.0])
    for _ in range(6):
        poses = rng.uniform(0.0, SIDE, (4, 2))
        z = sensor.sample(poses, np.broadcast_to(target, (4, 2)), rng)
        for grid in (full, pruned):
            grid.update(sensor, poses, z, np.array([True, True, False, True]))
    assert pruned.n_active < full.n_active
    np.testing.assert_allclose(pruned.mmse(), full.mmse(), rtol=0, atol=1e-12)
    assert pruned.mass_within(1.0, target) == pytest.approx(
        full.mass_within(1.0, target), abs=1e-12
    )


def test_no_received_measurement_leaves_the_posterior() -> None:
    grid = GridPosterior((0.0, 0.0), (SIDE, SIDE), cells=50)
    before = grid.log_posterior
    assert grid.update(BearingSensor(SIGMA), POSE[None], [[0.1]], np.array([False])) == 0.0
    np.testing.assert_array_equal(grid.log_posterior, before)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"low": (0.0,), "high": (1.0, 1.0)}, "low"),
        ({"low": (0.0, 0.0), "high": (1.0, math.nan)}, "high"),
        ({"low": (0.0, 0.0), "high": (1.0, -1.0)}, "high"),
        ({"low": (0.0, 0.0), "high": (1.0, 1.0), "cells": 1}, "cells"),
        ({"low": (0.0, 0.0), "high": (1.0, 1.0), "cells": (4, 4, 4)}, "cells"),
        ({"low": (0.0, 0.0), "high": (1.0, 1.0), "subcells": 0}, "subcells"),
        ({"low": (0.0, 0.0), "high": (1.0, 1.0), "prune": -1.0}, "prune"),
    ],
)
def test_bad_construction_names_the_argument(kwargs: dict[str, object], name: str) -> None:
    with pytest.raises(ValueError, match=name):
        GridPosterior(**kwargs)  # type: ignore[arg-type]


def test_bad_update_and_queries_name_the_argument() -> None:
    grid = GridPosterior((0.0, 0.0), (SIDE, SIDE), cells=20)
    sensor = BearingSensor(SIGMA)
    yes = np.array([True])
    with pytest.raises(ValueError, match="poses"):
        grid.update(sensor, [5.0, 5.0], [[0.1]], yes)
    with pytest.raises(ValueError, match="measurements"):
        grid.update(sensor, [[5.0, 5.0]], [[0.1], [0.2]], yes)
    with pytest.raises(ValueError, match="measurements"):
        grid.update(sensor, [[5.0, 5.0]], [[math.inf]], yes)
    with pytest.raises(ValueError, match="received"):
        grid.update(sensor, [[5.0, 5.0]], [[0.1]], [1])
    with pytest.raises(TypeError, match="sensor"):
        grid.update(object(), [[5.0, 5.0]], [[0.1]], yes)
    with pytest.raises(ValueError, match="radius"):
        grid.mass_within(-1.0, (1.0, 1.0))
    with pytest.raises(ValueError, match="radius"):
        grid.mass_within(math.nan, (1.0, 1.0))
    with pytest.raises(ValueError, match="centre"):
        grid.mass_within(1.0, (1.0, 1.0, 1.0))
    beacon = make("beacon_v0").unwrapped.config
    with pytest.raises(ValueError, match="config"):
        GridPosterior.from_config(beacon)


# ------------------------------------------------------------------ the study and its page
ROOT = Path(__file__).resolve().parents[1]
FIG1_STORE = ROOT / "experiments/results/fig1/store"
RESULTS = ROOT / "experiments/results/grid_posterior"


def test_reproduce_grid_posterior_reruns_the_stored_episodes(
    tmp_path: Path, fresh_cli: Callable[..., Any]
) -> None:
    """`infoseek reproduce grid_posterior --trials 1`: one trial per group, whose filter masses
    are the stored record's (read here from the store) and whose times to localise are those of
    its two mass series."""
    out = tmp_path / "gp"
    args = ["reproduce", "grid_posterior", "--trials", "1", "--workers", "1", "--out", str(out)]
    done = fresh_cli(args)
    assert done.returncode == 0, done.stdout + done.stderr
    trials, provenance = read_results(out)
    stored = {(v.planner, v.n_agents, v.trial): v for v in read_trials(FIG1_STORE)}
    assert sorted(t.planner for t in trials) == ["horizon", "pairwise", "single"]
    for trial in trials:
        view = stored[(trial.planner, 4, 0)]
        np.testing.assert_array_equal(np.float32(trial.filter_mass), np.float32(view.mass_agent0))
        for series, ttl in (
            (trial.filter_mass, trial.filter_ttl),
            (trial.grid_mass, trial.grid_ttl),
        ):
            first = time_to_localise(series)
            assert ttl == (60 if first is None else first)
        assert min(trial.grid_mass) >= 0.0 and max(trial.grid_mass) <= 1.0 + 1e-9
    assert provenance["config"]["env"] == "bearings_v0"
    assert provenance["numerics"]["pinned"] is True
    assert provenance["command"].startswith("infoseek reproduce grid_posterior --trials 1")


_DIFFERS = """
from infoseek.experiments.numerics import pin
pin()
from infoseek.experiments.studies.grid_posterior import FIG1_STORE, grid_specs, run_grid_trial
spec, view = next(grid_specs(FIG1_STORE, ["single"], 1))
run_grid_trial(spec, view.mass_agent0, 100)
stored = list(view.mass_agent0)
stored[7] += 1e-3
try:
    run_grid_trial(spec, stored, 100)
except RuntimeError as error:
    print(error)
"""


def test_a_rerun_that_differs_from_the_store_is_an_error(fresh_python: Callable[..., Any]) -> None:
    """The stored masses pass; the same masses with one step moved by 1e-3 raise."""
    done = fresh_python(_DIFFERS)
    assert done.returncode == 0, done.stderr
    assert "the rerun's filter masses differ from the store" in done.stdout


@pytest.mark.parametrize("option", [["--steps", "5"], ["--particles", "10"], ["--seed", "1"]])
def test_reproduce_grid_posterior_rejects_what_the_store_fixes(
    option: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "gp"
    assert main(["reproduce", "grid_posterior", "--trials", "1", *option, "--out", str(out)]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (out / "grid_posterior.json").exists()


def test_committed_page_is_what_its_results_give(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    page = PAGES["grid_posterior"]
    assert render_page("grid_posterior", page.default_results, page.default_page) == (
        page.default_page.read_text()
    ), "docs/results/grid_posterior.md differs from its results: run `infoseek page grid_posterior`"


def test_the_page_follows_its_results(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Changing the grid's times to localise in a copy of the results moves the page's grid
    mean for that planner to the mean computed here, and leaves the filter's."""
    monkeypatch.chdir(ROOT)
    body = json.loads((RESULTS / "grid_posterior.json").read_text())
    rows = [row for row in body["trials"] if row["trial"] < 20]
    for row in rows:
        if row["planner"] == "pairwise" and row["trial"] < 5:
            row["grid_ttl"] = 60
    body["trials"] = rows
    (tmp_path / "grid_posterior.json").write_text(json.dumps(body))
    text = render_page("grid_posterior", tmp_path, tmp_path / "page.md")
    pairwise = [row for row in rows if row["planner"] == "pairwise"]
    grid = np.mean([row["grid_ttl"] for row in pairwise])
    filt = np.mean([row["filter_ttl"] for row in pairwise])
    assert f"| `pairwise` | {len(pairwise)} | {filt:.2f} | {grid:.2f} |" in text
