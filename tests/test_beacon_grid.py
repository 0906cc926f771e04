"""The beacon grid study (``infoseek reproduce beacon_grid``) against the beacon store it
reruns, its options, and its page."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from infoseek.experiments.cli import main
from infoseek.experiments.pages.registry import PAGES, render_page
from infoseek.experiments.studies.beacon_grid import (
    HALVED_FILE,
    RESULTS_FILE,
    parse_group,
    read_results,
)

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "experiments/results/beacon_grid"

_RERUN = """
import json
import numpy as np
from infoseek.experiments.numerics import pin
pin()
from infoseek.experiments.analysis import time_to_localise
from infoseek.experiments.studies.beacon_grid import (
    BEACON_STORE, GridSettings, beacon_grid_specs, run_beacon_grid_trial,
)
spec, view = next(beacon_grid_specs(BEACON_STORE, [("single", 4)], 1))
grid = GridSettings(cells=100, orientation_cells=16)
trial = run_beacon_grid_trial(spec, view.mass_agent0, view.error_agent0, grid)
same = np.array_equal(np.float32(trial.filter_mass), np.float32(view.mass_agent0))
first = time_to_localise(trial.grid_mass)
print(json.dumps({"same": bool(same), "grid_ttl": trial.grid_ttl, "first": first,
                  "steps": len(trial.grid_mass), "max": max(trial.grid_mass),
                  "psi": max(trial.grid_psi_error)}))
moved = list(view.mass_agent0)
moved[7] += 1e-3
try:
    run_beacon_grid_trial(spec, moved, view.error_agent0, grid)
except RuntimeError as error:
    print(error)
"""


def test_a_rerun_is_the_stored_episode_and_a_different_one_is_an_error(
    fresh_python: Callable[..., Any],
) -> None:
    """Trial 0 of single/4 on a coarse grid (100 x 100 x 16): the rerun's filter masses are the
    stored ones, the grid's time to localise is that of its mass series, and the stored masses
    with one step moved by 1e-3 raise (a fresh interpreter: trial commands pin the numerics
    before NumPy loads)."""
    done = fresh_python(_RERUN)
    assert done.returncode == 0, done.stderr
    first, second = done.stdout.strip().splitlines()
    result = json.loads(first)
    assert result["same"] and result["steps"] == 41
    assert result["grid_ttl"] == (40 if result["first"] is None else result["first"])
    assert 0.0 <= result["max"] <= 1.0 + 1e-9 and 0.0 <= result["psi"] <= np.pi / 2
    assert "the rerun's filter masses differ from the store" in second


@pytest.mark.parametrize(
    "option",
    [
        ["beacon_grid", "--steps", "5"],
        ["beacon_grid", "--seed", "1"],
        ["beacon_grid", "--group", "pairwise"],
        ["beacon_grid", "--group", "nobody/4"],
        ["beacon_grid", "--store", "no/such/store"],
        ["grid_posterior", "--store", "experiments/results/beacon/store"],
        ["grid_posterior", "--halved-cells"],
    ],
)
def test_reproduce_beacon_grid_rejects_before_running(
    option: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(ROOT)
    out = tmp_path / "bg"
    assert main(["reproduce", *option, "--trials", "1", "--out", str(out)]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (out / RESULTS_FILE).exists()


def test_parse_group() -> None:
    assert parse_group("pairwise/4") == ("pairwise", 4)
    for bad in ("pairwise", "/4", "pairwise/0", "pairwise/x"):
        with pytest.raises(ValueError, match="PLANNER/N_AGENTS"):
            parse_group(bad)


def test_committed_results_are_the_stored_episodes() -> None:
    """Every committed trial's filter series are the beacon store's (the study checked it
    bit for bit when it ran; here against the store again), the times to localise those of
    the series, and the halved grid's trials a subset of the study's."""
    from infoseek.experiments.analysis import time_to_localise
    from infoseek.experiments.columns import read_trials

    trials, provenance = read_results(RESULTS)
    stored = {(v.planner, v.n_agents, v.trial): v for v in read_trials(ROOT / provenance["store"])}
    assert len(trials) >= 30
    for trial in trials:
        view = stored[(trial.planner, trial.n_agents, trial.trial)]
        np.testing.assert_array_equal(np.float32(trial.filter_mass), np.float32(view.mass_agent0))
        for series, ttl in (
            (trial.filter_mass, trial.filter_ttl),
            (trial.grid_mass, trial.grid_ttl),
        ):
            first = time_to_localise(series)
            assert ttl == (provenance["config"]["steps"] if first is None else first)
    halved, _ = read_results(RESULTS, HALVED_FILE)
    keys = {(t.planner, t.n_agents, t.trial) for t in trials}
    assert halved and {(t.planner, t.n_agents, t.trial) for t in halved} <= keys


def test_committed_page_is_what_its_results_give(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    page = PAGES["beacon_grid"]
    assert render_page("beacon_grid", page.default_results, page.default_page) == (
        page.default_page.read_text()
    ), "docs/results/beacon_grid.md differs from its results: run `infoseek page beacon_grid`"


def test_the_page_follows_its_results(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Changing the grid's times to localise in a copy of the results moves the page's exact
    mean to the mean computed here, and leaves the filter's."""
    monkeypatch.chdir(ROOT)
    body = json.loads((RESULTS / RESULTS_FILE).read_text())
    rows = body["trials"][:12]
    for row in rows[:4]:
        row["grid_ttl"] = 40
    body["trials"] = rows
    (tmp_path / RESULTS_FILE).write_text(json.dumps(body))
    text = render_page("beacon_grid", tmp_path, tmp_path / "page.md")
    group = f"{rows[0]['planner']}/{rows[0]['n_agents']}"
    grid = np.mean([row["grid_ttl"] for row in rows])
    filt = np.mean([row["filter_ttl"] for row in rows])
    assert f"| `{group}` | {len(rows)} | {filt:.2f} | {grid:.2f} |" in text
    assert "## Resolution check" not in text


def test_a_rerun_keeps_the_trials_already_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The study run twice into one directory, the second time with one more trial per group
    and another group: only the new trials run, the file holds the asked ones in order; a
    different grid runs everything again."""
    from infoseek.experiments.studies import beacon_grid

    ran: list[tuple[str, int, int]] = []

    def fake(spec: Any, mass: Any, error: Any, grid: Any) -> beacon_grid.BeaconGridTrial:
        ran.append((spec.planner, spec.n_agents, spec.trial))
        return beacon_grid.BeaconGridTrial(
            spec.planner, spec.n_agents, spec.trial, spec.env_seed, spec.policy_seed,
            (1.0, 2.0, 0.5), (0.0,), (1.0,), (0.0,), (1.0,), (0.1,), 40, 40, True, 0.1,
        )  # fmt: skip

    monkeypatch.chdir(ROOT)
    monkeypatch.setattr(beacon_grid, "run_beacon_grid_trial", fake)
    out = tmp_path / "bg"
    beacon_grid.reproduce_beacon_grid(out, trials=2, groups=[("pairwise", 4)])
    assert ran == [("pairwise", 4, 0), ("pairwise", 4, 1)]
    ran.clear()
    beacon_grid.reproduce_beacon_grid(out, trials=3, groups=[("pairwise", 4), ("single", 4)])
    assert ran == [("pairwise", 4, 2), ("single", 4, 0), ("single", 4, 1), ("single", 4, 2)]
    trials, _ = read_results(out)
    assert [(t.planner, t.trial) for t in trials] == [
        ("pairwise", 0), ("pairwise", 1), ("pairwise", 2), ("single", 0), ("single", 1),
        ("single", 2),
    ]  # fmt: skip
    ran.clear()
    coarse = beacon_grid.GridSettings(cells=100)
    beacon_grid.reproduce_beacon_grid(out, trials=1, groups=[("single", 4)], grid=coarse)
    assert ran == [("single", 4, 0)]
