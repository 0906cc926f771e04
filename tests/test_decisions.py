"""The decision-agreement study (infoseek.experiments.decision_differences, on bearings as
infoseek.experiments.studies.decisions and on the beacon as
infoseek.experiments.studies.beacon_mechanism), the switched planners
(infoseek.experiments.decisions) and the beacon mechanism section
(infoseek.experiments.pages.beacon_mechanism)."""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from scipy import stats

from infoseek.envs import beacon_v0, bearings_v0
from infoseek.experiments.decision_differences import (
    BEARINGS_DECISIONS,
    largest_component_difference,
)
from infoseek.experiments.decisions import (
    BEACON_SWITCHED_PLANNERS,
    PAIRWISE_STEPS,
    SWITCHED_PLANNERS,
    PairwiseThenSingle,
    pairwise_first_10_steps,
    pairwise_first_20_steps,
)
from infoseek.experiments.environments import import_object
from infoseek.experiments.pages.beacon_mechanism import mechanism_lines
from infoseek.experiments.policies import make_policy
from infoseek.experiments.record import trial_key
from infoseek.experiments.seeds import trial_seeds
from infoseek.experiments.store import ResultsStore
from infoseek.experiments.studies import beacon_mechanism
from infoseek.experiments.studies.beacon_mechanism import (
    BEACON_DECISIONS,
    BEACON_V1_KWARGS,
    SWITCHED_GROUPS,
    reproduce_beacon_mechanism,
    switched_plan,
)
from infoseek.experiments.studies.decisions import (
    DIFFERENT_TURN_RATE,
    DecisionRow,
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


ROOT = Path(__file__).resolve().parents[1]
V1_KWARGS = {"resample_threshold": 0.5, "tempering_ess": 0.5}


def test_bearings_files_are_written_byte_for_byte_as_committed(tmp_path: Path) -> None:
    """The generalised writer gives the committed ablation decisions files from their rows."""
    committed = ROOT / "experiments/results/ablation"
    rows = read_decisions(committed)
    assert rows is not None
    write_decisions(tmp_path, rows)
    for name in ("decisions.json", "decisions.md"):
        assert (tmp_path / name).read_bytes() == (committed / name).read_bytes()
    assert read_decisions(committed, BEARINGS_DECISIONS) == rows
    with pytest.raises(ValueError, match="beacon_v0"):
        read_decisions(committed, BEACON_DECISIONS)


def test_distance_is_the_largest_component_difference() -> None:
    assert largest_component_difference([0.5, -1.0], [0.2, -0.9]) == pytest.approx(0.3)
    assert largest_component_difference([-0.25], [0.5]) == 0.75
    assert BEACON_DECISIONS.threshold == 0.2  # 10 % of the per-axis range [-1, 1]
    assert BEARINGS_DECISIONS.threshold == DIFFERENT_TURN_RATE == 0.1


def test_beacon_differences_replay_a_pairwise_episode_with_a_single_node_shadow(
    tmp_path: Path,
) -> None:
    """A 3-step beacon_v1 episode with 300 particles: the differences are the largest
    per-axis acceleration differences of the two planners, counted against 0.2."""
    kwargs = {**V1_KWARGS, "n_particles": 300, "max_cycles": 3}
    setting = replace(BEACON_DECISIONS, env_kwargs=kwargs)
    differences = trial_differences(3, 1, 0, setting)
    assert differences.shape == (3, 3)
    env_seed, pairwise_seed = trial_seeds(0, "beacon_v0", "pairwise", 3, 1)
    _, single_seed = trial_seeds(0, "beacon_v0", "single", 3, 1)
    env = beacon_v0.parallel_env(n_agents=3, belief_in_infos=True, **kwargs)
    observations, infos = env.reset(seed=env_seed)
    pairwise = make_policy("pairwise", env, seed=pairwise_seed)
    single = make_policy("single", env, seed=single_seed)
    expected = np.zeros((3, 3))
    for step in range(3):
        actions = pairwise.act(observations, infos)
        shadow = single.act(observations, infos)
        for i, agent in enumerate(env.possible_agents):
            a, b = np.asarray(actions[agent]), np.asarray(shadow[agent])
            assert a.shape == (2,)
            expected[step, i] = max(abs(float(b[0] - a[0])), abs(float(b[1] - a[1])))
        observations, _, _, _, infos = env.step(actions)
    np.testing.assert_allclose(differences, expected)
    rows = summarise_differences(3, [expected, expected[::-1]], setting)
    assert [(r.start, r.stop) for r in rows] == [(0, 1), (1, 5)]  # 3 steps: two phases
    later = np.concatenate([expected[1:], expected[::-1][1:]])
    fractions = [np.mean(expected[1:] > 0.2), np.mean(expected[::-1][1:] > 0.2)]
    assert rows[1].differ == pytest.approx(np.mean(fractions))
    assert rows[1].mean_abs_difference == pytest.approx(later.mean())
    write_decisions(tmp_path, rows, setting)
    payload = json.loads((tmp_path / "decisions.json").read_text())
    assert payload["env"] == "beacon_v0"
    assert payload["env_kwargs"] == kwargs
    assert payload["different_acceleration"] == 0.2
    assert read_decisions(tmp_path, setting) == rows
    table = (tmp_path / "decisions.md").read_text()
    assert "largest per-axis acceleration difference" in table
    assert "units/s^2 |" in table and "rad/s" not in table


@pytest.mark.parametrize(
    ("factory", "steps"), [(pairwise_first_10_steps, 10), (pairwise_first_20_steps, 20)]
)
def test_beacon_switched_factories(factory: Any, steps: int) -> None:
    env = beacon_v0.parallel_env(n_agents=2, n_particles=100, belief_in_infos=True)
    planner = factory(env, seed=4)
    assert isinstance(planner, PairwiseThenSingle)
    assert planner.pairwise_steps == steps
    label = f"infoseek.experiments.decisions:{factory.__name__}"
    assert label in BEACON_SWITCHED_PLANNERS
    assert label not in SWITCHED_PLANNERS  # the ablation runs every one of those
    assert PAIRWISE_STEPS[label] == steps
    assert (label, 4) in SWITCHED_GROUPS
    assert import_object(label, "planner") is factory


def test_switched_plan_is_the_beacon_v1_study_run() -> None:
    """Same environment, keywords, steps and seed as the beacon_v1 study's store, so trial k
    pairs with its trial k."""
    plan = switched_plan(7)
    assert plan.config()["env"] == "beacon_v0"
    assert plan.config()["env_kwargs"] == V1_KWARGS
    assert (plan.steps, plan.seed, plan.trials) == (40, 0, 7)
    assert plan.groups == [(label, 4) for label in BEACON_SWITCHED_PLANNERS]
    assert BEACON_V1_KWARGS == V1_KWARGS


def test_reproduce_resumes_by_fleet_size(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Stored fleet sizes are not rerun, the largest runs first, the switched plan is run into
    OUT/switched/store; another trial count is refused."""
    ran: list[int] = []
    benched: list[tuple[Any, Path]] = []

    def rows(n_agents: int, trials: int, workers: int, setting: object) -> list[DecisionRow]:
        ran.append(n_agents)
        return [DecisionRow(n_agents, 0, 1, trials, 0.0, 0.0, 0.0)]

    def bench(plan: Any, store: Path, **options: Any) -> Any:
        benched.append((plan, store))
        return SimpleNamespace(ran=0, skipped=0)

    monkeypatch.setattr(beacon_mechanism, "beacon_decision_rows", rows)
    monkeypatch.setattr(beacon_mechanism, "run_bench", bench)
    paths = reproduce_beacon_mechanism(
        tmp_path, decision_trials=3, switched_trials=5, workers=1, fleets=(4, 2)
    )
    assert ran == [4, 2]
    assert paths == [tmp_path / "decisions.md", tmp_path / "decisions.json", benched[0][1]]
    assert benched[0][1] == tmp_path / "switched" / "store"
    assert benched[0][0].trials == 5
    stored = read_decisions(tmp_path, BEACON_DECISIONS) or []
    assert [r.n_agents for r in stored] == [2, 4]
    reproduce_beacon_mechanism(
        tmp_path, decision_trials=3, switched_trials=5, workers=1, fleets=(2, 3, 4)
    )
    assert ran == [4, 2, 3]
    with pytest.raises(ValueError, match="from 3 trials"):
        reproduce_beacon_mechanism(tmp_path, decision_trials=4, switched_trials=5, workers=1)


STEPS = 24
STORE_CONFIG = {"env": "beacon_v0", "env_kwargs": V1_KWARGS, "steps": STEPS, "seed": 0}
FIRST_10, FIRST_20 = BEACON_SWITCHED_PLANNERS


def _write_store(
    directory: Path,
    groups: dict[str, range],
    rng: np.random.Generator,
    masses: dict[tuple[str, int], np.ndarray] | None = None,
) -> dict:
    """A store of ``n_agents = 4`` trials with random mass series (``masses[planner, trial]``
    where given); returns ``{planner: {trial: time to localise}}`` computed here (first step
    with mass >= 0.9, else ``STEPS``) and ``{planner: {trial: mass}}`` under ``"mass"``."""
    times: dict[str, dict[int, Any]] = {}
    with ResultsStore(directory, {**STORE_CONFIG, "version": "t"}) as store:
        for planner, trials in groups.items():
            for trial in trials:
                mass = rng.uniform(0.0, 1.0, STEPS + 1).astype(np.float32).astype(float)
                mass = (masses or {}).get((planner, trial), mass)
                hits = [step for step, value in enumerate(mass) if value >= 0.9]
                times.setdefault(planner, {})[trial] = float(hits[0] if hits else STEPS)
                times.setdefault("mass", {})[planner, trial] = mass
                store.append(
                    {
                        "key": trial_key(planner, 4, trial),
                        "planner": planner,
                        "n_agents": 4,
                        "trial": trial,
                        "env_seed": 100 + trial,
                        "policy_seed": trial,
                        "mass_agent0": mass.tolist(),
                        "plan_time": [0.001] * STEPS,
                    }
                )
    return times


def _expected_row(name: str, against: str, mine: dict, theirs: dict) -> str:
    common = sorted(set(mine) & set(theirs))
    a = np.array([mine[k] for k in common])
    b = np.array([theirs[k] for k in common])
    gain = b - a
    se = gain.std(ddof=1) / np.sqrt(gain.size)
    one = stats.wilcoxon(b, a, alternative="greater").pvalue if gain.any() else 1.0
    two = stats.wilcoxon(b, a).pvalue if gain.any() else 1.0
    return (
        f"| {name} | {against} | {len(common)} | {a.mean():.2f} | {b.mean():.2f} "
        f"| {gain.mean():+.2f} +- {se:.2f} | {one:.3g} | {two:.3g} |"
    )


def test_mechanism_section_pairs_partial_stores_by_trial(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    main_store, out = tmp_path / "store", tmp_path / "out"
    times = _write_store(main_store, {"single": range(12), "pairwise": range(20)}, rng)
    pairwise_mass = times.pop("mass")
    prefix = np.concatenate([pairwise_mass["pairwise", 1][:11], np.full(STEPS - 10, 0.5)])
    copied = {
        (FIRST_10, 0): pairwise_mass["pairwise", 0],
        (FIRST_10, 1): prefix,  # pairwise-node's through step 10 only
        (FIRST_20, 4): pairwise_mass["pairwise", 4],
    }
    times |= _write_store(
        out / "switched" / "store", {FIRST_10: range(15), FIRST_20: range(3, 10)}, rng, copied
    )
    rows = [
        DecisionRow(4, 0, 1, 30, 0.0, 0.0, 0.0),
        DecisionRow(4, 1, 5, 30, 0.225, 0.023, 0.165),
        DecisionRow(4, 5, 10, 30, 0.12, 0.018, 0.09),
    ]
    write_decisions(out, rows, BEACON_DECISIONS)
    text = "\n\n".join(mechanism_lines(out, main_store))
    claim = _expected_row("pairwise throughout", "single", times["pairwise"], times["single"])
    assert claim in text
    for label in (FIRST_10, FIRST_20):
        name = BEACON_SWITCHED_PLANNERS[label]
        for against in ("single", "pairwise"):
            assert _expected_row(name, against, times[label], times[against]) in text
    assert format_decisions(rows, BEACON_DECISIONS) in text
    assert "differ: 0 % at step 0, 12-22 % in each later phase (n_v = 4)." in text
    assert "| pairwise at steps 0-19, then single | single | 7 |" in text  # trials 3-9
    p = stats.wilcoxon(
        *(np.array([times[g][k] for k in range(12)]) for g in ("single", "pairwise")),
        alternative="greater",
    ).pvalue
    heading = "beats" if p < 0.05 else "does not beat"
    assert text.startswith(f"## Why pairwise-node {heading} single-node on `beacon_v1`")
    assert (
        "(pairwise at steps 0-9, then single: through step 10 in 2 of 15 paired trials, over the "
        "whole episode in 1; pairwise at steps 0-19, then single: through step 20 in 1 of 7 "
        "paired trials, over the whole episode in 1)." in text
    )
    with pytest.raises(ValueError, match="switched/store"):
        mechanism_lines(tmp_path / "nothing", main_store)
