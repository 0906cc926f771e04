"""The decision-agreement study (infoseek.experiments.studies.decisions) and the switched planner
(infoseek.experiments.decisions)."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from infoseek.envs import bearings_v0
from infoseek.experiments.decisions import PairwiseThenSingle
from infoseek.experiments.policies import make_policy
from infoseek.experiments.seeds import trial_seeds
from infoseek.experiments.studies.decisions import (
    DIFFERENT_TURN_RATE,
    format_decisions,
    read_decisions,
    summarise_differences,
    trial_differences,
    write_decisions,
)


def test_summary_matches_a_direct_count() -> None:
    rng = np.random.default_rng(0)
    per_trial = [rng.uniform(0.0, 0.3, size=(60, 3)) for _ in range(4)]
    per_trial[1][30:] = np.nan  # an episode that ended early
    rows = summarise_differences(3, per_trial)
    for row in rows:
        fractions = []
        for d in per_trial:
            values = [v for v in d[row.start : row.stop].ravel() if np.isfinite(v)]
            if values:
                fractions.append(sum(v > DIFFERENT_TURN_RATE for v in values) / len(values))
        assert row.trials == len(fractions)
        assert row.differ == pytest.approx(np.mean(fractions))
        assert row.differ_se == pytest.approx(np.std(fractions, ddof=1) / np.sqrt(len(fractions)))
    late = [r for r in rows if r.start == 20][0]
    assert late.trials == 4  # trial 1 still has steps 20-29


def test_differences_replay_a_pairwise_episode_with_a_single_node_shadow(tmp_path) -> None:
    differences = trial_differences(2, 0)
    assert differences.shape == (60, 2)
    env_seed, pairwise_seed = trial_seeds(0, "bearings_v0", "pairwise", 2, 0)
    _, single_seed = trial_seeds(0, "bearings_v0", "single", 2, 0)
    env = bearings_v0.parallel_env(n_agents=2, belief_in_infos=True)
    observations, infos = env.reset(seed=env_seed)
    pairwise = make_policy("pairwise", env, seed=pairwise_seed)
    single = make_policy("single", env, seed=single_seed)
    for step in range(3):
        actions = pairwise.act(observations, infos)
        shadow = single.act(observations, infos)
        expected = [abs(float(shadow[a][0]) - float(actions[a][0])) for a in env.possible_agents]
        np.testing.assert_allclose(differences[step], expected)
        observations, _, _, _, infos = env.step(actions)
    rows = summarise_differences(2, [differences])
    write_decisions(tmp_path, rows)
    np.testing.assert_equal(
        [asdict(r) for r in read_decisions(tmp_path) or []], [asdict(r) for r in rows]
    )
    assert format_decisions(rows).count("\n| 2 | ") == len(rows)
    assert read_decisions(tmp_path / "missing") is None


def test_switched_planner_is_pairwise_then_single() -> None:
    def env():
        built = bearings_v0.parallel_env(n_agents=3, n_particles=300, belief_in_infos=True)
        observations, infos = built.reset(seed=5)
        return built, observations, infos

    switched_env, observations, infos = env()
    switched = PairwiseThenSingle(switched_env, 2, seed=3)
    reference_env, _, _ = env()
    pairwise = make_policy("pairwise", reference_env, seed=3)
    single = make_policy("single", reference_env, seed=3)
    for step in range(4):
        actions = switched.act(observations, infos)
        expected = (pairwise if step < 2 else single).act(observations, infos)
        for agent in actions:
            np.testing.assert_array_equal(actions[agent], expected[agent])
        observations, _, _, _, infos = switched_env.step(actions)
    switched.reset()
    assert switched.steps_taken == 0


@pytest.mark.parametrize(("value", "error"), [(-1, ValueError), (1.5, TypeError)])
def test_switched_planner_rejects_bad_steps(value: object, error: type) -> None:
    built = bearings_v0.parallel_env(n_agents=2, n_particles=100, belief_in_infos=True)
    with pytest.raises(error, match="pairwise_steps"):
        PairwiseThenSingle(built, value, seed=0)  # type: ignore[arg-type]
