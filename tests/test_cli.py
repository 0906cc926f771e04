"""Smoke and error tests of the ``infoseek`` command (tiny settings)."""

from __future__ import annotations

import dataclasses
import json
import platform
import shutil
import subprocess
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy
from PIL import Image

from infoseek.experiments.analysis import format_p_value, mass_curves
from infoseek.experiments.cli import build_parser, main
from infoseek.experiments.columns import TrialView
from infoseek.experiments.plot import fig1_panels
from infoseek.experiments.record import TrialRecord
from infoseek.experiments.store import (
    MANIFEST_NAME,
    PARTS_NAME,
    TRIALS_NAME,
    read_manifest,
    read_records,
)
from infoseek.experiments.studies.claims import distance_lines, mass_bands, start_centre


def _view(
    planner: str,
    n_agents: int,
    trial: int,
    mass: list[float] | np.ndarray,
    truth: np.ndarray | None = None,
) -> TrialView:
    """A stored trial with agent 0's mass series ``mass`` (and target ``truth``)."""
    return TrialView(
        planner=planner,
        n_agents=n_agents,
        trial=trial,
        env_seed=trial,
        radius=1.0,
        truth=truth,
        mass_agent0=np.asarray(mass, dtype=float),
        error_agent0=None,
        plan_time=np.zeros(len(mass) - 1),
    )


BENCH_TINY = ["--agents", "2", "--steps", "3", "--particles", "100", "--workers", "1"]


def _snapshot(directory: Path) -> dict[str, bytes]:
    return {str(p): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def bench_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench") / "run"
    code = main(["bench", "--planner", "random", "--trials", "2", *BENCH_TINY, "--out", str(out)])
    assert code == 0
    return out


def test_demo_smoke(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["demo", "--steps", "3", "--particles", "200", "--out", str(tmp_path)])
    assert code == 0
    lines = capsys.readouterr().out.splitlines()
    assert sum(line.split()[0] in {"1", "2", "3"} for line in lines if line.strip()) == 3
    (gif,) = tmp_path.glob("*.gif")
    with Image.open(gif) as image:
        assert image.n_frames == 4  # the reset frame and one per step
    assert len(list(tmp_path.glob("*.png"))) == 1


def test_timing_smoke(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["timing", "--repeats", "1", "--only", "env_step_bearings_4"]) == 0
    assert "env_step_bearings_4" in capsys.readouterr().out


def test_timing_planned_beacon_v1_step_smoke(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The beacon issue's step benchmark times env.step along a planned episode: one timed
    step after the warm-up, its mean equal to its median for one call, and the 5 ms target."""
    out = tmp_path / "timing.json"
    argv = ["timing", "--repeats", "1", "--only", "env_step_beacon_v1_4_planned"]
    assert main([*argv, "--json", str(out)]) == 0
    assert "env_step_beacon_v1_4_planned" in capsys.readouterr().out
    row = json.loads(out.read_text())["results"]["env_step_beacon_v1_4_planned"]
    assert row["calls"] == 1 and row["target_ms"] == 5.0
    assert row["mean_ms"] == pytest.approx(row["median_ms"]) and row["median_ms"] > 0.0


@pytest.mark.parametrize("statistic", ["median", "mean"])
def test_timing_alternates_with_a_baseline_checkout(
    statistic: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--baseline runs both versions in fresh processes, A B per round, and reports B / A of
    the calls' median or mean (here the baseline is this checkout itself, imported through the
    temporary package tree)."""
    root = Path(__file__).resolve().parents[1]
    out = tmp_path / "ab.json"
    argv = ["timing", "--repeats", "3", "--only", "env_step_bearings_4", "--rounds", "1"]
    argv += ["--statistic", statistic]
    assert main([*argv, "--baseline", str(root), "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "B / A" in printed and "env_step_bearings_4" in printed
    assert f"their {statistic} compared" in printed
    report = json.loads(out.read_text())
    assert report["statistic"] == statistic
    (row,) = report["results"]["env_step_bearings_4"]["rounds"]
    assert row["ratio"] == pytest.approx(row["b_ms"] / row["a_ms"])
    assert main([*argv, "--baseline", str(tmp_path)]) == 2  # not a checkout: before any work
    assert "is not an infoseek checkout" in capsys.readouterr().err


def test_timing_mean_refuses_a_baseline_that_reports_medians_only(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A baseline whose ``infoseek timing`` predates the mean column (310eb30, say) cannot be
    compared by mean: one line, exit 2, before any benchmark runs."""
    for name in ("envs", "planners", "baselines", "experiments"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text("")
    (tmp_path / "experiments" / "timing.py").write_text(
        'BENCHMARKS = ("env_step_bearings_4",)\nROW = {"median_ms": 1.0}\n'
    )
    argv = ["timing", "--repeats", "1", "--only", "env_step_bearings_4", "--rounds", "1"]
    assert main([*argv, "--statistic", "mean", "--baseline", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "reports medians only" in err and len(err.strip().splitlines()) == 1


def test_timing_statistic_needs_a_baseline(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["timing", "--repeats", "1", "--only", "env_step_bearings_4", "--statistic", "mean"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--statistic compares --baseline runs" in err and len(err.strip().splitlines()) == 1


def test_bench_smoke_stores_and_summarises(
    bench_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    manifest = json.loads((bench_dir / MANIFEST_NAME).read_text())
    assert manifest["config"]["env"] == "bearings_v0"
    assert manifest["config"]["steps"] == 3
    assert manifest["config"]["env_kwargs"] == {"n_particles": 100}
    records = read_records(bench_dir)
    assert (bench_dir / TRIALS_NAME).read_bytes() == b""  # compacted into a part
    assert sorted(r.key for r in records) == [
        "random/agents=2/trial=0",
        "random/agents=2/trial=1",
    ]
    # rerun: nothing to do, the summary is printed from the store
    before = _snapshot(bench_dir)
    code = main(
        ["bench", "--planner", "random", "--trials", "2", *BENCH_TINY, "--out", str(bench_dir)]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "0 trial(s) run, 2 of 2 already stored" in out
    row = next(line for line in out.splitlines() if line.startswith("random"))
    assert row.split()[1:3] == ["2", "2"]
    assert _snapshot(bench_dir) == before


def test_plot_smoke(bench_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    stem = tmp_path / "figure"
    assert main(["plot", str(bench_dir), "--out", str(stem)]) == 0
    with Image.open(stem.with_suffix(".png")) as image:
        assert image.size[0] > 300 and image.size[1] > 200
    assert "<svg" in stem.with_suffix(".svg").read_text()[:500]
    assert "wrote" in capsys.readouterr().out


def test_fig1_panels_follow_the_paper() -> None:
    groups = [("pairwise", 10), ("single", 4), ("pairwise", 2), ("pairwise", 4), ("random", 4)]
    assert fig1_panels(groups) == [
        ("a", [("single", 4), ("pairwise", 4), ("random", 4)]),
        ("b", [("pairwise", 2), ("pairwise", 4), ("pairwise", 10)]),
    ]
    with_horizon = [("horizon", 10), ("horizon", 4), ("horizon", 2), *groups]
    assert fig1_panels(with_horizon)[2] == ("c", [("horizon", 2), ("horizon", 4), ("horizon", 10)])
    # a horizon group without its pairwise partner has no paired difference to draw
    assert fig1_panels([("horizon", 3), *groups])[2:] == []
    assert fig1_panels(with_horizon)[0][1][2] == ("horizon", 4)
    assert fig1_panels([("random", 4), ("lawnmower", 4)]) == [
        ("all", [("lawnmower", 4), ("random", 4)])
    ]
    assert fig1_panels([("single", 4)]) == [("a", [("single", 4)])]
    assert fig1_panels([("pairwise", 3)]) == [("b", [("pairwise", 3)])]
    assert fig1_panels([("random", 2), ("lawnmower", 2)]) == [
        ("all", [("lawnmower", 2), ("random", 2)])
    ]


def test_mass_curves_pad_short_trials() -> None:
    records = [_view("p", 2, 0, [0.0, 0.5, 1.0]), _view("p", 2, 1, [0.0, 0.95])]
    np.testing.assert_array_equal(
        mass_curves(records)["p", 2], [[0.0, 0.5, 1.0], [0.0, 0.95, 0.95]]
    )


def test_reproduce_fig1_smoke(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["reproduce", "fig1", "--trials", "1", "--steps", "2", "--particles", "100"]
    assert main([*args, "--workers", "1", "--out", str(tmp_path)]) == 0
    records = read_records(tmp_path / "store")
    assert sorted((r.planner, r.n_agents) for r in records) == [
        ("pairwise", 2),
        ("pairwise", 3),
        ("pairwise", 4),
        ("pairwise", 10),
        ("single", 4),
    ]
    assert (tmp_path / "fig1.png").exists() and (tmp_path / "fig1.svg").exists()


def test_reproduce_beacon_smoke(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["reproduce", "beacon", "--trials", "1", "--steps", "2", "--particles", "100"]
    assert main([*args, "--workers", "1", "--out", str(tmp_path)]) == 0
    records = read_records(tmp_path / "store")
    assert sorted((r.planner, r.n_agents) for r in records) == [
        ("lawnmower", 4),
        ("pairwise", 2),
        ("pairwise", 3),
        ("pairwise", 4),
        ("random", 4),
        ("single", 4),
    ]
    assert read_manifest(tmp_path / "store")["config"]["env"] == "beacon_v0"
    assert (tmp_path / "beacon.png").exists() and (tmp_path / "beacon.svg").exists()


def test_reproduce_beacon_v1_smoke(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The beacon_v1 study runs beacon_v0 with beacon_v1's two filter settings (so its trials
    pair with the beacon study's), then the decisions study and the switched planners with the
    same steps and particles, and writes its page."""
    args = ["reproduce", "beacon_v1", "--trials", "2", "--steps", "2", "--particles", "100"]
    page = tmp_path / "page.md"
    out = tmp_path / "beacon_v1"
    assert main([*args, "--workers", "1", "--out", str(out), "--page", str(page)]) == 0
    config = read_manifest(out / "store")["config"]
    assert config["env"] == "beacon_v0" and config["steps"] == 2
    assert config["env_kwargs"] == {
        "n_particles": 100,
        "resample_threshold": 0.5,
        "tempering_ess": 0.5,
    }
    assert len(read_records(out / "store")) == 12
    switched = read_manifest(out / "switched" / "store")["config"]
    assert switched == config
    assert sorted({r.planner for r in read_records(out / "switched" / "store")}) == [
        "infoseek.experiments.decisions:pairwise_first_10_steps",
        "infoseek.experiments.decisions:pairwise_first_20_steps",
    ]
    decisions = json.loads((out / "decisions.json").read_text())
    assert {row["n_agents"] for row in decisions["rows"]} == {2, 3, 4}
    text = page.read_text()
    assert "# Beacon Monte Carlo on beacon_v1" in text and "against beacon_v0" not in text


def test_reproduce_fig2_smoke(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["reproduce", "fig2", "--steps", "2", "--particles", "100", "--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    psi = float(out.split(" psi ")[1].split()[0])
    assert abs(psi - np.pi / 4) <= 0.02  # the paper's true orientation
    assert "t =  1:" in out and "t =  2:" in out
    with Image.open(tmp_path / "fig2.png") as image:
        assert image.size[0] > 400


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["bench", "--planner", "nope"], "unknown planner 'nope'"),
        (["bench", "--trials", "0"], "--trials must be >= 1"),
        (["bench", "--trials", "-3"], "--trials must be >= 1"),
        (["bench", "--env", "nope_v9"], "unknown environment 'nope_v9'"),
        (["bench", "--agents", "0"], "--agents must be >= 1"),
        (["bench", "--agents", "two"], "expected integers"),
        (["bench", "--backend", "mpi"], "unknown backend 'mpi'"),
        (["bench", "--policy", "no-such-model.zip"], "no such file"),
        (["reproduce", "fig1", "--trials", "0"], "--trials must be >= 1"),
        (["reproduce", "fig3"], "invalid choice"),
        (["plot", "/nonexistent/infoseek-results"], "no such results directory"),
    ],
)
def test_bad_arguments_exit_2_with_a_message(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    if argv[0] == "bench":
        argv = [*argv, "--out", str(tmp_path / "never")]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "never").exists()


def test_other_configuration_is_refused_and_untouched(
    bench_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = _snapshot(bench_dir)
    tiny = [a if a != "3" else "5" for a in BENCH_TINY]  # --steps 5 instead of 3
    code = main(["bench", "--planner", "random", "--trials", "2", *tiny, "--out", str(bench_dir)])
    assert code == 2
    err = capsys.readouterr().err
    assert "holds results of another configuration" in err and "steps: stored 3" in err
    assert _snapshot(bench_dir) == before


def test_plot_without_trials_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / MANIFEST_NAME).write_text(
        json.dumps({"format": "infoseek-bench-store", "format_version": 1, "config": {}})
    )
    assert main(["plot", str(tmp_path)]) == 2
    assert "nothing to plot" in capsys.readouterr().err


def _synthetic_store(directory: Path, times: dict[tuple[str, int], list[int]], steps: int) -> None:
    """A results store whose trial ``k`` of each group first reaches mass 0.9 at ``times[k]``."""
    from infoseek.experiments.store import FORMAT, MANIFEST_NAME, TRIALS_NAME

    directory.mkdir(parents=True)
    manifest = {  # format 2 (no checksums), which stays readable: hand-written JSON lines
        "config": {"env": "bearings_v0", "env_kwargs": {}, "seed": 0, "steps": steps},
        "format": FORMAT,
        "format_version": 2,
    }
    (directory / MANIFEST_NAME).write_text(json.dumps(manifest))
    lines = []
    for (planner, n_agents), ttls in times.items():
        for trial, ttl in enumerate(ttls):
            mass = [0.5] * ttl + [0.95] * (steps + 1 - ttl)
            lines.append(
                json.dumps(
                    {
                        "key": f"{planner}/agents={n_agents}/trial={trial}",
                        "planner": planner,
                        "n_agents": n_agents,
                        "trial": trial,
                        "env_seed": 1000 + trial,
                        "mass_agent0": mass,
                        "plan_time": [0.001] * steps,
                    }
                )
            )
    (directory / TRIALS_NAME).write_text("\n".join(lines) + "\n")


def test_claims_detects_a_paired_improvement_and_its_absence(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(0)
    base = rng.integers(10, 30, size=40)
    faster = base - rng.integers(1, 3, size=40)  # pairwise always 1-2 steps sooner
    times = {
        ("single", 4): base.tolist(),
        ("pairwise", 4): faster.tolist(),
        ("pairwise", 2): (faster + 3).tolist(),
        ("pairwise", 10): (faster - 3).tolist(),
    }
    _synthetic_store(tmp_path / "holds", times, steps=60)
    assert main(["claims", str(tmp_path / "holds")]) == 0
    out = capsys.readouterr().out
    assert "Claim A" in out and "-> holds" in out.split("Claim A")[1].split("\n")[0]
    assert "-> holds" in out.split("Claim B")[1].split("\n")[0]

    # Same times for both planners and a fleet-size order that is reversed: neither claim.
    times = {
        ("single", 4): base.tolist(),
        ("pairwise", 4): base.tolist(),
        ("pairwise", 2): (base - 3).tolist(),
        ("pairwise", 10): (base + 3).tolist(),
    }
    _synthetic_store(tmp_path / "fails", times, steps=60)
    assert main(["claims", str(tmp_path / "fails")]) == 0
    out = capsys.readouterr().out
    assert "not supported" in out.split("Claim A")[1].split("\n")[0]
    assert "not supported" in out.split("Claim B")[1].split("\n")[0]

    # --trials N keeps trials 0..N-1 of every group; a non-positive N is refused.
    assert main(["claims", str(tmp_path / "holds"), "--trials", "12"]) == 0
    out = capsys.readouterr().out
    assert "Claim A (n_v = 4, pairwise faster than single): 12 paired trials" in out
    assert main(["claims", str(tmp_path / "holds"), "--trials", "0"]) == 2
    assert "--trials must be a positive" in capsys.readouterr().err


def test_claim_b_with_two_fleet_sizes_is_decided_by_the_paired_wilcoxon_test(
    tmp_path: Path, capsys
) -> None:
    rng = np.random.default_rng(4)
    base = rng.integers(10, 30, size=30)
    for name, shift, verdict in (("holds", 3, "holds"), ("fails", -3, "not supported")):
        times = {("pairwise", 4): base.tolist(), ("pairwise", 2): (base + shift).tolist()}
        _synthetic_store(tmp_path / name, times, steps=60)
        assert main(["claims", str(tmp_path / name)]) == 0
        line = capsys.readouterr().out.split("Claim B")[1].split("\n")[0]
        assert "two fleet sizes" in line and f"-> {verdict}" in line


def test_claim_a_reports_the_paired_mean_mass_difference(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(6)
    single = rng.integers(4, 25, size=25)
    pairwise = single - rng.integers(-1, 3, size=25)
    _synthetic_store(
        tmp_path / "store", {("single", 4): single.tolist(), ("pairwise", 4): pairwise.tolist()}, 40
    )
    assert main(["claims", str(tmp_path / "store")]) == 0
    line = capsys.readouterr().out.split("mean posterior mass over steps 0-40, pairwise - single: ")
    gap, rest = line[1].split(" +- ", 1)

    def mean_mass(ttl: np.ndarray) -> np.ndarray:  # 0.5 before the time to localise, then 0.95
        return (0.5 * ttl + 0.95 * (41 - ttl)) / 41

    difference = mean_mass(pairwise) - mean_mass(single)
    assert float(gap) == pytest.approx(difference.mean(), abs=6e-5)
    assert float(rest.split(" ")[0]) == pytest.approx(
        difference.std(ddof=1) / np.sqrt(25), abs=6e-5
    )
    assert float(rest.split("p = ")[1].split("\n")[0]) < 0.05  # pairwise is mostly faster


def test_claims_report_where_the_horizon_planner_gains_mass(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(5)
    pairwise = rng.integers(4, 25, size=30)
    horizon = pairwise - rng.integers(0, 4, size=30)
    times = {("pairwise", 4): pairwise.tolist(), ("horizon", 4): horizon[:20].tolist()}
    _synthetic_store(tmp_path / "store", times, steps=40)
    assert main(["claims", str(tmp_path / "store")]) == 0
    line = capsys.readouterr().out.split("horizon - pairwise paired mass, 20 trials: ")[1]
    cells = line.split("\n")[0].split(", ")
    for step, cell in zip((5, 10, 15, 20, 30), cells, strict=True):
        # mass 0.95 from the time to localise on, 0.5 before it (the synthetic store)
        gain = 0.45 * ((horizon[:20] <= step) & (pairwise[:20] > step))
        mean, se = (float(v) for v in cell.split(": ")[1].split(" +- "))
        assert cell.startswith(f"step {step}: ")
        assert mean == pytest.approx(gain.mean(), abs=6e-4)
        assert se == pytest.approx(gain.std(ddof=1) / np.sqrt(20), abs=6e-4)


def test_claims_against_a_baseline_store_are_paired_differences(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(2)
    old = rng.integers(10, 30, size=25)
    new = old + rng.integers(-2, 1, size=25)  # never slower, often faster
    _synthetic_store(tmp_path / "old", {("pairwise", 4): old.tolist()}, steps=60)
    _synthetic_store(tmp_path / "new", {("pairwise", 4): new.tolist()}, steps=60)
    assert main(["claims", str(tmp_path / "new"), "--baseline", str(tmp_path / "old")]) == 0
    line = capsys.readouterr().out.split("Against the baseline")[1].splitlines()[1]
    difference = new - old
    stderr = difference.std(ddof=1) / np.sqrt(25)
    assert f"mean ttl {new.mean():.2f} (baseline {old.mean():.2f})" in line
    assert f"difference {difference.mean():+.2f} +- {stderr:.2f}" in line
    _synthetic_store(tmp_path / "short", {("pairwise", 4): old.tolist()}, steps=40)
    assert main(["claims", str(tmp_path / "new"), "--baseline", str(tmp_path / "short")]) == 2
    assert "not paired" in capsys.readouterr().err


def test_distance_fit_recovers_a_linear_time_to_localise() -> None:
    rng = np.random.default_rng(4)
    records = []
    for trial in range(30):
        truth = rng.uniform(10, 40, 2)
        ttl = int(round(0.5 * np.hypot(*(truth - 5.0)))) + 3
        mass = [0.5] * ttl + [0.95] * (61 - ttl)
        records.append(_view("pairwise", 4, trial, mass, truth))
    (line,) = distance_lines(records, 60, {4: np.array([5.0, 5.0])})
    d = np.array([np.hypot(*(np.asarray(r.truth) - 5.0)) for r in records])
    y = np.array([list(r.mass_agent0).index(0.95) for r in records])
    slope, intercept = np.polyfit(d, y, 1)
    assert f"ttl = {slope:.2f} d0 {intercept:+.2f}" in line and abs(slope - 0.5) < 0.05
    # a bound exactly linear in d0 is fitted exactly, after the planner's line
    exact = {4: {r.trial: 2.0 * dist + 1.0 for r, dist in zip(records, d, strict=True)}}
    lines = distance_lines(records, 60, {4: np.array([5.0, 5.0])}, exact)
    assert lines[0] == line
    assert lines[1].startswith("  bound/4: ttl = 2.00 d0 +1.00 (correlation 1.00, residual sd 0.00")


def test_start_centre_is_the_mean_of_the_fleets_start_grid() -> None:
    from infoseek.envs import bearings_v0

    np.testing.assert_allclose(start_centre("bearings_v0", {}, 4), [5.0, 5.0])
    spread = start_centre("bearings_v0", {"start_spacing": 6.0}, 10)
    env = bearings_v0.parallel_env(n_agents=10, start_spacing=6.0)
    observations, infos = env.reset(seed=0)
    positions = infos[env.possible_agents[0]]["vehicle_states"][:, :2]
    np.testing.assert_allclose(spread, positions.mean(axis=0))


def test_claims_rejects_unpaired_stores(tmp_path: Path, capsys) -> None:
    _synthetic_store(tmp_path / "s", {("single", 4): [5, 6], ("pairwise", 4): [4, 5]}, steps=20)
    trials = (tmp_path / "s" / "trials.jsonl").read_text().splitlines()
    record = json.loads(trials[-1])
    record["env_seed"] = 7
    trials[-1] = json.dumps(record)
    (tmp_path / "s" / "trials.jsonl").write_text("\n".join(trials) + "\n")
    assert main(["claims", str(tmp_path / "s")]) == 2
    assert "not paired" in capsys.readouterr().err


def test_bench_accepts_a_planner_factory_path(tmp_path: Path) -> None:
    out = tmp_path / "factory"
    argv = ["bench", "--env", "bearings_v0", "--agents", "2", "--trials", "1", "--steps", "2"]
    argv += ["--particles", "100", "--out", str(out), "--no-progress"]
    factory = "infoseek.planners:SingleNodePlanner.from_env"
    assert main([*argv, "--planner", factory]) == 0
    (record,) = read_records(out)
    assert record.planner == factory and len(record.plan_time) == 2
    assert main([*argv, "--planner", "infoseek.planners:NoSuchPlanner.from_env"]) == 2


def test_p_values_that_underflow_print_as_a_bound() -> None:
    assert format_p_value(0.0123) == "= 0.0123"
    assert format_p_value(4.2e-87) == "= 4.2e-87"
    assert format_p_value(0.0) == "< 2.23e-308"  # Page's normal approximation underflows


def test_mass_bands_are_the_mean_and_interquartile_range_per_step() -> None:
    rng = np.random.default_rng(4)
    series = rng.uniform(0.0, 1.0, (9, 21))
    records = [_view("single", 4, trial, row) for trial, row in enumerate(series)]
    line = mass_bands(records, [("single", 4)])
    assert line.strip().startswith("single/4 mass mean (IQR):")
    for step in (5, 10, 15, 20):
        column = np.sort(series[:, step])
        # 9 values: the 25th and 75th percentiles are the 3rd and 7th order statistics.
        expected = f"step {step}: {column.mean():.3f} ({column[6] - column[2]:.3f})"
        assert expected in line


def _rewrite_as_journal(out: Path, records: list[TrialRecord]) -> None:
    """The store ``out`` holding exactly ``records``, in its journal (double precision), as
    infoseek writes it (checksummed lines, the manifest listing no part)."""
    from infoseek.experiments import store

    manifest = store.read_manifest(out)
    shutil.rmtree(out / PARTS_NAME)
    store._write_manifest(out, {**manifest, "parts": {}})
    lines = [store.encode_journal_line(record.to_row()) for record in records]
    (out / TRIALS_NAME).write_bytes(b"".join(lines))


def test_verify_reruns_stored_trials_and_names_the_ones_not_reproduced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    tiny = ["--steps", "3", "--particles", "100", "--workers", "1"]
    args = ["bench", "--planner", "single", "--agents", "2", "--trials", "3", *tiny]
    assert main([*args, "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["verify", str(out), "--workers", "1"]) == 0
    assert "3 stored trial(s) rerun: 3 reproduced exactly" in capsys.readouterr().out

    # Tamper with a result of trial 1 (a real divergence at the last step), a timing field of
    # trial 2 (ignored) and a result of trial 0 by 1e-7 (floating-point noise).
    records = read_records(out)
    mass = list(records[1].mass_agent0)
    last = len(mass) - 1
    mass[-1] = mass[-1] / 2 + 0.01
    records[1] = dataclasses.replace(records[1], mass_agent0=tuple(mass))
    plan_time = tuple(t + 1.0 for t in records[2].plan_time)
    records[2] = dataclasses.replace(records[2], plan_time=plan_time)
    error = list(records[0].error_agent0)
    error[1] += 1e-7
    records[0] = dataclasses.replace(records[0], error_agent0=tuple(error))
    _rewrite_as_journal(out, records)
    before = _snapshot(out)
    assert main(["verify", str(out), "--workers", "1"]) == 1
    report = capsys.readouterr().out
    assert f"{records[1].key}: diverged from step {last}; differs in mass_agent0" in report
    assert records[2].key not in report and records[0].key not in report
    assert "3 stored trial(s) rerun: 1 reproduced exactly, 1 equal within tolerance" in report
    assert "1 not reproduced" in report
    assert _snapshot(out) == before  # verify never writes to the store

    # --trials / --group select what is rerun.
    assert main(["verify", str(out), "--trials", "1", "--group", "single/2", "--workers", "1"]) == 0
    assert (
        "1 stored trial(s) rerun: 0 reproduced exactly, 1 equal within" in capsys.readouterr().out
    )
    for bad, message in (
        (["--group", "single"], "--group must look like PLANNER/AGENTS"),
        (["--group", "pairwise/4"], "no stored trials of group(s) pairwise/4"),
        (["--trials", "0"], "--trials must be a positive"),
    ):
        assert main(["verify", str(out), *bad, "--workers", "1"]) == 2
        assert message in capsys.readouterr().err


def test_the_pin_leaves_numpy_no_avx512_loop_whatever_its_version_calls_them(
    fresh_python: Callable[..., Any],
) -> None:
    """In the pinned environment NumPy dispatches to no AVX-512 target. NumPy 2.4 names them
    X86_V4, AVX512_ICL, AVX512_SPR; earlier versions AVX512F ... AVX512_CNL, and a pin with
    only the new names left NumPy 2.3.5 on its AVX-512 loops (5 of 13 Fig. 1 trial 0s then
    diverged)."""
    probe = "from infoseek.experiments.numerics import describe; print(describe()['numpy_simd'])"
    run = fresh_python(probe, pinned=True)
    targets = json.loads(run.stdout.replace("'", '"'))
    assert targets, run.stderr
    assert not [t for t in targets if t.startswith("AVX512") or t == "X86_V4"], targets


def test_stored_trials_verify_under_another_blas_kernel(
    tmp_path: Path, fresh_cli: Callable[..., Any]
) -> None:
    """A stored trial verifies with another BLAS kernel asked for through OPENBLAS_CORETYPE
    (trial commands pin the numerical environment of infoseek.experiments.numerics before
    NumPy loads), and under a second numba target: the compiled kernels' IEEE arithmetic gives
    the same bits whatever code numba generates."""
    out = tmp_path / "run"
    args = ["--planner", "pairwise", "--agents", "3", "--trials", "1", "--steps", "8"]
    args += ["--particles", "400", "--workers", "1", "--no-progress"]
    written = fresh_cli(["bench", *args, "--out", str(out)])
    assert written.returncode == 0, written.stderr
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    assert manifest["numerics"]["pinned"] is True
    assert {b["kernel"] for b in manifest["numerics"]["blas"]} == {"Haswell"}
    assert manifest["numerics"]["scipy"] == scipy.__version__
    assert manifest["numerics"]["libc"] == (" ".join(platform.libc_ver()).strip() or "unknown")
    for kernel in ("SkylakeX", "Sandybridge"):
        checked = fresh_cli(["verify", str(out), "--no-progress"], OPENBLAS_CORETYPE=kernel)
        assert checked.returncode == 0, checked.stdout + checked.stderr
        assert "1 reproduced exactly" in checked.stdout
        assert f"C library {manifest['numerics']['libc']}" in checked.stdout
    numba = manifest["numerics"]["numba"]
    assert numba["fastmath"] is False and numba["svml"] is False
    other = "generic" if numba["cpu_name"] != "generic" else "x86-64"
    checked = fresh_cli(["verify", str(out), "--no-progress"], NUMBA_CPU_NAME=other)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert f"target {other}" in checked.stdout
    assert "1 reproduced exactly" in checked.stdout


RL_BENCH_STORE = (
    Path(__file__).resolve().parents[1] / "experiments" / "results" / "rl" / "bench_20_steps"
)


@pytest.mark.parametrize("instructions", ["SSE4_2", "AVX2"])
def test_stored_policy_trials_verify_whatever_instructions_mkl_may_use(
    instructions: str, fresh_cli: Callable[..., Any]
) -> None:
    """A stored trained-policy trial (torch, which links MKL) reproduces with MKL limited to
    another instruction set: the pin selects MKL's CPU-independent branch, and the features
    take their square roots outside MKL's CPU-dependent vector library. Without the pin, MKL's
    matrix products and vector functions give other last bits on an AVX-512 CPU than with
    ``MKL_ENABLE_INSTRUCTIONS=AVX2``."""
    pytest.importorskip("stable_baselines3")
    group = ["--group", "policy:../ppo_20_step_episodes/model.zip/4"]
    checked = fresh_cli(
        ["verify", str(RL_BENCH_STORE), "--trials", "1", *group, "--no-progress"],
        MKL_ENABLE_INSTRUCTIONS=instructions,
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "1 stored trial(s) rerun: 1 reproduced exactly" in checked.stdout


FIG1_STORE = Path(__file__).resolve().parents[1] / "experiments" / "results" / "fig1" / "store"


def test_committed_fig1_trials_reproduce_on_this_machine(fresh_cli: Callable[..., Any]) -> None:
    """The stored Fig. 1 results are the installed code's: the first trial of two groups is
    rerun from its seeds and must reproduce (in the pinned numerical environment)."""
    assert (FIG1_STORE / MANIFEST_NAME).exists()
    groups = ["--group", "single/4", "--group", "pairwise/3"]
    checked = fresh_cli(["verify", str(FIG1_STORE), "--trials", "1", *groups, "--no-progress"])
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "2 stored trial(s) rerun: 2 reproduced exactly" in checked.stdout


# Every binary32 function of the C library as the double function rounded to float: what a
# correctly rounded libm (glibc's CORE-MATH float functions) returns but for ~2^-29 of values.
_ROUNDED_FLOAT_LIBM = """
#include <math.h>
#define F1(f, d) float f(float x) { return (float) d((double) x); }
#define F2(f, d) float f(float x, float y) { return (float) d((double) x, (double) y); }
F2(atan2f, atan2) F1(atanf, atan) F1(asinf, asin) F1(acosf, acos) F1(erff, erf) F1(erfcf, erfc)
F1(expm1f, expm1) F1(log1pf, log1p) F1(cbrtf, cbrt) F1(coshf, cosh) F1(sinhf, sinh)
F1(tanhf, tanh) F2(hypotf, hypot) F1(expf, exp) F1(logf, log) F2(powf, pow) F1(sinf, sin)
F1(cosf, cos) F1(tanf, tan) F1(exp2f, exp2) F1(log2f, log2) F1(log10f, log10)
"""


def test_committed_fig1_trial_reproduces_under_a_correctly_rounded_float_libm(
    tmp_path: Path, fresh_python: Callable[..., Any], fresh_cli: Callable[..., Any]
) -> None:
    """The stored trials do not depend on the C library's float functions: with every one of
    them replaced (LD_PRELOAD) by the correctly rounded value, which newer glibc returns and
    which differs from glibc 2.36's atan2f in about one value in six, trial 0 of pairwise/10
    still reproduces (it diverged from step 3 while the planners used NumPy's float32 arctan2,
    which calls the C library's atan2f in the pinned environment)."""
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None or sys.platform != "linux":
        pytest.skip("needs a C compiler and Linux to build the replacement libm")
    source = tmp_path / "rounded_float_libm.c"
    source.write_text(_ROUNDED_FLOAT_LIBM)
    library = tmp_path / "rounded_float_libm.so"
    built = subprocess.run(
        [compiler, "-O2", "-shared", "-fPIC", "-o", str(library), str(source), "-lm"],
        capture_output=True,
        text=True,
    )
    assert built.returncode == 0, built.stderr
    probe = "import numpy as np; y = np.array([0x42740099], np.uint32).view(np.float32); "
    probe += "x = np.array([0x429678C0], np.uint32).view(np.float32); "
    probe += "print(hex(int(np.arctan2(y, x).view(np.uint32)[0])))"
    replaced = fresh_python(probe, pinned=True, LD_PRELOAD=str(library))
    assert replaced.returncode == 0, replaced.stderr
    if replaced.stdout.strip() != "0x3f2e68cd":  # glibc 2.36's fdlibm value: 0x3f2e68cc
        pytest.skip("LD_PRELOAD did not replace the C library's atan2f in this environment")
    group = ["--group", "pairwise/10"]
    checked = fresh_cli(
        ["verify", str(FIG1_STORE), "--trials", "1", *group, "--no-progress"],
        LD_PRELOAD=str(library),
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "1 stored trial(s) rerun: 1 reproduced exactly" in checked.stdout


def test_committed_ablation_trial_of_a_switched_planner_reproduces(
    fresh_cli: Callable[..., Any],
) -> None:
    """The stored Claim A ablation is the installed code's: trial 0 of the planner that runs
    pairwise-node for five steps, then single-node, is rerun and must reproduce."""
    store = FIG1_STORE.parent.parent / "ablation" / "default" / "store"
    group = "infoseek.experiments.decisions:pairwise_first_5_steps/4"
    checked = fresh_cli(["verify", str(store), "--trials", "1", "--group", group, "--no-progress"])
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "1 stored trial(s) rerun: 1 reproduced exactly" in checked.stdout


def test_claims_on_one_trial_per_group_says_what_it_needs(tmp_path: Path, capsys) -> None:
    """One trial per group gives no standard error: the claims say so instead of printing
    ``+- nan`` (and no NumPy warning escapes)."""
    times = {("single", 4): [12], ("pairwise", 4): [11], ("pairwise", 2): [15]}
    _synthetic_store(tmp_path / "one", times, steps=60)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["claims", str(tmp_path / "one")]) == 0
    out = capsys.readouterr().out
    assert "Claim A: needs at least 2 paired trials of single/4 and pairwise/4, has 1" in out
    assert "Claim B: needs at least 2 paired trials of every pairwise group, has 1" in out
    assert "nan" not in out


def test_bench_agents_repeated_adds_fleet_sizes() -> None:
    """``--agents 2 --agents 3`` runs both sizes (argparse kept only the last one)."""
    parsed = build_parser().parse_args(["bench", "--agents", "2", "--agents", "3,4"])
    assert [n for group in parsed.agents for n in group] == [2, 3, 4]


def test_reproduce_horizon_adds_its_groups_to_a_fig1_store_and_writes_its_page(
    tmp_path: Path,
) -> None:
    """``reproduce horizon``: the Fig. 1 groups and the study's groups in one store (paired by
    trial), Fig. 1 redrawn, the horizon page written from that store."""
    args = ["reproduce", "horizon", "--trials", "2", "--steps", "2", "--particles", "100"]
    page = tmp_path / "horizon.md"
    assert main([*args, "--workers", "1", "--out", str(tmp_path), "--page", str(page)]) == 0
    groups = {(r.planner, r.n_agents) for r in read_records(tmp_path / "store")}
    assert groups == {
        ("single", 4),
        ("pairwise", 2),
        ("pairwise", 3),
        ("pairwise", 4),
        ("pairwise", 10),
        ("horizon", 2),
        ("horizon", 4),
        ("horizon", 10),
        ("infoseek.experiments.clairvoyant:fisher_reference", 4),
    }
    text = page.read_text()
    assert "Horizon (n_v = 4, horizon faster than pairwise): 2 paired trials" in text
    svg = (tmp_path / "fig1.svg").read_bytes()
    assert main(["plot", str(tmp_path / "store"), "--out", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again.svg").read_bytes() == svg  # the same figure, the same bytes


def test_a_study_directory_given_for_its_store_is_pointed_to_the_store(
    tmp_path: Path, fresh_cli: Callable[..., Any]
) -> None:
    """``infoseek claims OUT`` after ``infoseek reproduce ... --out OUT``: the one-line error
    names ``OUT/store``."""
    _synthetic_store(tmp_path / "store", {("single", 4): [3, 4]}, steps=10)
    result = fresh_cli(["claims", str(tmp_path)])
    assert result.returncode == 2
    assert result.stderr.strip().endswith(f"the results store of a study run is {tmp_path}/store")
    assert len(result.stderr.strip().splitlines()) == 1
