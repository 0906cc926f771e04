"""Imitation of the MI planners (behaviour cloning + DAgger) and PPO fine-tuning from it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from infoseek.baselines import load_policy
from infoseek.baselines.expert_rollouts import LabelledBatch, RolloutTask, run_rollouts
from infoseek.baselines.imitation import ImitationConfig, fit_policy, train_imitation
from infoseek.baselines.training import TrainingConfig, train
from infoseek.envs import make
from infoseek.experiments.cli import main
from infoseek.planners import PairwiseNodePlanner

SMALL = {"n_particles": 200, "max_cycles": 12, "belief_moments": True}


def _config(**overrides: object) -> ImitationConfig:
    settings: dict[str, object] = {
        "n_agents": 2,
        "iterations": 1,
        "episodes_per_iteration": 2,
        "episode_steps": 6,
        "epochs": 2,
        "eval_episodes": 1,
        "net_arch": (16, 16),
        "env_kwargs": SMALL,
    }
    settings.update(overrides)
    return ImitationConfig(**settings)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def imitation_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("dagger")
    train_imitation(_config(), out)
    return out


def test_a_run_writes_a_loadable_ppo_model_and_its_curve(imitation_run: Path) -> None:
    config = json.loads((imitation_run / "config.json").read_text())
    assert (config["trainer"], config["algo"], config["labelled_states"]) == ("dagger", "ppo", 48)
    curve = (imitation_run / "eval.csv").read_text().splitlines()
    assert len(curve) == 3 and curve[0].startswith("iteration,beta,labelled_states")
    env = make("bearings_v0", n_agents=2, **SMALL)
    policy = load_policy(imitation_run, env)
    observations, infos = env.reset(seed=0)
    actions = policy.act(observations, infos)
    assert all(env.action_space(a).contains(actions[a]) for a in env.agents)


def _replayed_labels(seed: int, model: str | None) -> tuple[np.ndarray, np.ndarray]:
    """Four steps of seed ``seed`` replayed by hand: every agent's observation and the
    pairwise planner's action for it, the vehicles driven by the planner (``model`` None) or
    by the policy ``model``."""
    env = make("bearings_v0", n_agents=2, belief_in_infos=True, **SMALL)
    driver = None if model is None else load_policy(model, env)
    expert = PairwiseNodePlanner.from_env(env, seed=seed)
    observations, infos = env.reset(seed=seed)
    rows, labels = [], []
    for _ in range(4):
        wanted = expert.act(observations, infos)
        rows += [observations[a] for a in env.agents]
        labels += [wanted[a] for a in env.agents]
        actions = wanted if driver is None else driver.act(observations, infos)
        observations, _, _, _, infos = env.step(actions)
    return np.stack(rows), np.stack(labels).astype(np.float32)


def test_cloning_labels_are_the_experts_decisions_on_its_own_episode() -> None:
    task = RolloutTask("bearings_v0", {"n_agents": 2, **SMALL}, "pairwise", None, 1.0, (5,), 4)
    batch = run_rollouts(task, num_cpus=0)
    rows, labels = _replayed_labels(5, None)
    np.testing.assert_array_equal(batch.observations, rows)
    np.testing.assert_array_equal(batch.actions, labels)
    assert (batch.steps, batch.learner_steps) == (4, 0)


def test_dagger_with_beta_zero_follows_the_learner_and_labels_with_the_expert(
    imitation_run: Path,
) -> None:
    model = str(imitation_run / "model.zip")
    task = RolloutTask("bearings_v0", {"n_agents": 2, **SMALL}, "pairwise", model, 0.0, (9,), 4)
    batch = run_rollouts(task, num_cpus=0)
    rows, labels = _replayed_labels(9, model)
    np.testing.assert_array_equal(batch.observations, rows)
    np.testing.assert_array_equal(batch.actions, labels)
    assert batch.learner_steps == 4


def test_fit_reaches_a_learnable_target_and_sets_the_ml_standard_deviation(
    imitation_run: Path,
) -> None:
    policy = load_policy(imitation_run)
    model = policy.model
    rng = np.random.default_rng(0)
    low, high = model.observation_space.low, model.observation_space.high
    observations = rng.uniform(low, high, size=(512, low.size)).astype(np.float32)
    actions = np.full((512, 1), 0.3, dtype=np.float32)
    data = LabelledBatch(observations, actions)
    config = _config(epochs=60, learning_rate=3e-3, batch_size=128)
    loss = fit_policy(model, data, config, np.random.default_rng(1))
    assert loss < 1e-3
    with torch.no_grad():
        predicted = model.policy.get_distribution(torch.as_tensor(observations)).mode().numpy()
    rms = np.sqrt(np.mean((predicted - actions) ** 2))
    np.testing.assert_allclose(
        np.exp(model.policy.log_std.detach().numpy()), max(rms, 1e-3), rtol=1e-5
    )


def test_ppo_starts_from_the_imitation_weights(imitation_run: Path, tmp_path: Path) -> None:
    config = TrainingConfig(
        n_agents=2,
        timesteps=24,
        n_envs=1,
        env_kwargs=SMALL,
        hyperparameters={"n_steps": 12, "batch_size": 24, "learning_rate": 1e-12, "n_epochs": 1},
        eval_freq=0,
        eval_episodes=1,
        checkpoint_freq=0,
        init_from=str(imitation_run / "model.zip"),
    )
    train(config, tmp_path, progress=False)
    start = load_policy(imitation_run).model.policy.state_dict()
    tuned = load_policy(tmp_path).model.policy.state_dict()
    for name, value in start.items():
        torch.testing.assert_close(tuned[name], value, atol=1e-6, rtol=0)
    assert json.loads((tmp_path / "config.json").read_text())["hyperparameters"]["net_arch"] == [
        16,
        16,
    ]


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("infoseek train: error: "), err
    return err[0]


def test_bad_imitation_input_fails_in_one_line_before_any_work(
    imitation_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    base = ["train", "--algo", "dagger", "--out", str(out), "--particles", "200"]
    assert main([*base, "--expert", "joint", "--agents", "4"]) == 2
    assert "JointPlanner" in _error_line(capsys)
    assert main([*base, "--expert", "oracle"]) == 2
    assert "expert" in _error_line(capsys)
    assert main([*base, "--timesteps", "100"]) == 2
    assert "--timesteps" in _error_line(capsys)
    ppo = ["train", "--algo", "ppo", "--timesteps", "10", "--out", str(out), "--agents", "4"]
    assert main([*ppo, "--init", str(imitation_run / "model.zip")]) == 2
    assert "observation space" in _error_line(capsys)
    assert not out.exists()
