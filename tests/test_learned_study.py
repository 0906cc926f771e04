"""The learned-policy study's statistics against direct computations, and its settings."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
import pytest
from scipy import stats

from infoseek.experiments.studies.learned import (
    BENCHES,
    MASS_STEP,
    SETTINGS,
    interquartile_mean,
    paired_result,
)
from infoseek.experiments.train import add_train_arguments


@dataclass(frozen=True)
class _Trial:
    planner: str
    n_agents: int
    trial: int
    env_seed: int
    mass_agent0: tuple[float, ...]
    plan_time: tuple[float, ...]
    radius: float = 1.0
    truth: tuple[float, ...] | None = None
    error_agent0: tuple[float, ...] | None = None


def test_interquartile_mean_drops_the_outer_quarters() -> None:
    values = [17.9, 17.1, 30.0, 17.4, 1.0]
    result = interquartile_mean(values)
    assert result.value == pytest.approx(np.mean([17.1, 17.4, 17.9]))
    assert result.low <= result.value <= result.high
    constant = interquartile_mean([2.5] * 5)
    assert constant.value == constant.low == constant.high == 2.5
    with pytest.raises(ValueError, match=">= 2"):
        interquartile_mean([1.0])


def _series(localised_at: int, steps: int, late_mass: float) -> tuple[float, ...]:
    return tuple(0.95 if t >= localised_at else late_mass * t / steps for t in range(steps + 1))


def test_paired_result_matches_a_direct_computation() -> None:
    rng = np.random.default_rng(3)
    steps = 40
    planner_ttl = rng.integers(5, 41, size=30)
    policy_ttl = np.clip(planner_ttl + rng.integers(-3, 3, size=30), 5, 41)
    trials = []
    for k in range(30):
        trials.append(_Trial("pairwise", 4, k, k, _series(planner_ttl[k], steps, 0.5), (0.004,)))
        trials.append(_Trial("policy:p", 4, k, k, _series(policy_ttl[k], steps, 0.6), (0.0004,)))
    result = paired_result(trials, "policy:p", trials, "pairwise", steps)
    expected_planner = np.minimum(planner_ttl, steps).astype(float)
    expected_policy = np.minimum(policy_ttl, steps).astype(float)
    assert result.trials == 30
    assert result.planner_ttl == pytest.approx(expected_planner.mean())
    assert result.policy_ttl == pytest.approx(expected_policy.mean())
    difference = expected_planner - expected_policy
    assert result.ttl_gain[0] == pytest.approx(difference.mean())
    assert result.ttl_gain[1] == pytest.approx(difference.std(ddof=1) / np.sqrt(30))
    wilcoxon = stats.wilcoxon(expected_planner, expected_policy, alternative="greater")
    assert result.ttl_gain[2] == pytest.approx(wilcoxon.pvalue)
    policy_mass = np.array([_series(t, steps, 0.6)[MASS_STEP] for t in policy_ttl])
    planner_mass = np.array([_series(t, steps, 0.5)[MASS_STEP] for t in planner_ttl])
    assert result.policy_mass == pytest.approx(policy_mass.mean())
    assert result.mass_gain[0] == pytest.approx((policy_mass - planner_mass).mean())
    assert (result.policy_ms, result.planner_ms) == pytest.approx((0.4, 4.0))


def test_every_bench_names_a_setting_and_every_setting_parses_as_a_train_command() -> None:
    names = {setting.name for setting in SETTINGS}
    assert {bench.setting for bench in BENCHES} <= names
    parser = argparse.ArgumentParser()
    add_train_arguments(parser)
    for setting in SETTINGS:
        args = parser.parse_args(setting.train_command(3, "out")[1:])
        assert (args.algo, args.env, args.expert, args.seed) == (
            "dagger",
            setting.env,
            setting.expert,
            3,
        )
