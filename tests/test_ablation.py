"""The Claim A ablation's statistics (against a direct computation) and its stores/figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from infoseek.experiments.bench import run_bench
from infoseek.experiments.cli import main
from infoseek.experiments.columns import TrialView
from infoseek.experiments.studies.ablation import (
    SETTINGS,
    AblationSetting,
    ablation_plans,
    ablation_rows,
    gap_row,
    write_results,
)


def _records(rng: np.random.Generator, trials: int, steps: int) -> list[TrialView]:
    records = []
    for planner, lift in (("single", 0.0), ("pairwise", 0.05)):
        for trial in range(trials):
            mass = np.clip(np.sort(rng.uniform(0, 1, steps + 1)) + lift, 0, 1)
            records.append(
                TrialView(
                    planner=planner,
                    n_agents=4,
                    trial=trial,
                    env_seed=trial,
                    radius=1.0,
                    truth=None,
                    mass_agent0=mass,
                    error_agent0=None,
                    plan_time=np.zeros(steps),
                )
            )
    return records


def test_gap_row_is_the_paired_difference_of_the_trials() -> None:
    rng = np.random.default_rng(0)
    steps, trials = 12, 30
    records = _records(rng, trials, steps)
    row = gap_row(SETTINGS[0], records, steps, 4)
    single = np.array([r.mass_agent0 for r in records if r.planner == "single"])
    pairwise = np.array([r.mass_agent0 for r in records if r.planner == "pairwise"])
    diff = pairwise.mean(axis=1) - single.mean(axis=1)
    assert row.trials == trials
    assert row.mass_gap == pytest.approx(diff.mean())
    assert row.mass_gap_se == pytest.approx(diff.std(ddof=1) / np.sqrt(trials))
    expected_p = stats.wilcoxon(diff, alternative="greater").pvalue
    assert row.mass_p == pytest.approx(expected_p)
    np.testing.assert_allclose(row.gap_curve, (pairwise - single).mean(axis=0))

    def ttl(m: np.ndarray) -> float:
        hit = np.flatnonzero(m >= 0.9)
        return float(hit[0]) if hit.size else float(steps)

    gain = np.array([ttl(s) - ttl(p) for s, p in zip(single, pairwise, strict=True)])
    assert row.ttl_gap == pytest.approx(gain.mean())
    assert row.ttl_single == pytest.approx(np.mean([ttl(s) for s in single]))


def test_gap_row_needs_paired_trials() -> None:
    records = _records(np.random.default_rng(1), 1, 5)
    with pytest.raises(ValueError, match="paired trials"):
        gap_row(SETTINGS[0], records, 5, 4)


def test_ablation_stores_table_and_figure(tmp_path: Path) -> None:
    tiny = (
        AblationSetting(
            "a",
            "particles",
            "100",
            {"n_particles": 100},
            (2,),
            (("infoseek.experiments.decisions:pairwise_first_step", 2),),
        ),
        AblationSetting(
            "b", "sigma", "0.3", {"n_particles": 100, "sensor_kwargs": {"sigma": 0.3}}, (2,)
        ),
    )
    for name, plan in ablation_plans(trials=2, steps=3, settings=tiny):
        run_bench(plan, tmp_path / name / "store", progress=False)
    rows = ablation_rows(tmp_path, settings=tiny)
    assert [(r.setting, r.planner, r.n_agents, r.trials) for r in rows] == [
        ("a", "pairwise", 2, 2),
        ("a", "infoseek.experiments.decisions:pairwise_first_step", 2, 2),
        ("b", "pairwise", 2, 2),
    ]
    assert len(rows[0].gap_curve) == 4
    paths = write_results(tmp_path, rows)
    assert {p.name for p in paths} == {
        "ablation.md",
        "ablation.json",
        "ablation.png",
        "ablation.svg",
    }
    table = (tmp_path / "ablation.md").read_text()
    assert "| particles | 100 | pairwise | 2 | 2 |" in table
    assert "| particles | 100 | pairwise at step 0, then single | 2 | 2 |" in table


def test_every_setting_is_a_valid_environment() -> None:
    for _, plan in ablation_plans(trials=1):
        plan.validate()


def test_reproduce_ablation_rejects_steps_and_particles(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "ablation", "--particles", "500"]) == 2
    assert "fixed by its settings" in capsys.readouterr().err
