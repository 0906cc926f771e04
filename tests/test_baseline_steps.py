"""Tests of the steps the RL baselines' ``train``, ``train_imitation`` and ``evaluate_policy``
are built from."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from infoseek.baselines.callbacks import (  # noqa: E402
    PeriodicEvaluationCallback,
    PruningCheckpointCallback,
    TqdmProgressCallback,
)
from infoseek.baselines.evaluation import _episode_metrics, evaluate_policy  # noqa: E402
from infoseek.baselines.imitation import (  # noqa: E402
    ImitationConfig,
    _evaluation_env,
    _policy_model,
)
from infoseek.baselines.training import (  # noqa: E402
    TrainingConfig,
    _already_trained,
    _fresh_model,
    _initial_model,
    _resume_point,
    _training_callbacks,
)
from infoseek.baselines.vec_env import make_training_vec_env  # noqa: E402

torch.set_num_threads(1)

TINY_ENV = {"n_particles": 100, "max_cycles": 10}


class ScriptedEnv:
    """A parallel environment of two agents whose infos and rewards follow a script."""

    def __init__(self, steps: int, agents_after_reset: tuple[str, ...] = ("a", "b")) -> None:
        self.steps = steps
        self.initial_agents = list(agents_after_reset)
        self.agents: list[str] = []
        self.t = 0

    def _infos(self) -> dict[str, dict[str, float]]:
        return {
            "a": {"entropy": 5.0 - self.t, "posterior_mass": 0.25 * self.t},
            "b": {"entropy": 4.0 - 0.5 * self.t, "posterior_mass": 0.125 * self.t},
        }

    def reset(self, seed: int) -> tuple[dict[str, int], dict[str, dict[str, float]]]:
        self.t = 0
        self.agents = list(self.initial_agents)
        if not self.initial_agents:
            return {}, {}
        return {a: self.t for a in self.initial_agents}, self._infos()

    def step(self, actions: dict[str, int]) -> tuple[Any, ...]:
        self.t += 1
        if self.t >= self.steps:
            self.agents = []
        rewards = {"a": 1.0, "b": 2.0 * self.t}
        done = {a: False for a in ("a", "b")}
        return {a: self.t for a in ("a", "b")}, rewards, done, done, self._infos()


class EndedEnv(ScriptedEnv):
    """An episode whose agents are listed after the reset but that is already over."""

    @property
    def agents(self) -> list[str]:
        listed, self._listed = self._listed, []
        return listed

    @agents.setter
    def agents(self, agents: list[str]) -> None:
        self._listed = agents


class RecordingPolicy:
    def __init__(self) -> None:
        self.seen: list[dict[str, int]] = []

    def act(self, observations: dict[str, int], infos: Any) -> dict[str, int]:
        self.seen.append(dict(observations))
        return {a: 0 for a in observations}


def test_an_episode_gives_the_means_over_agents_of_its_metrics() -> None:
    policy = RecordingPolicy()
    reduction, final, mean, episode_return, steps = _episode_metrics(policy, ScriptedEnv(3), 7)
    assert steps == 3
    assert policy.seen == [{"a": 0, "b": 0}, {"a": 1, "b": 1}, {"a": 2, "b": 2}]
    assert reduction == pytest.approx(np.mean([3.0, 1.5]))  # H(0) - H(3) per agent
    assert final == pytest.approx(np.mean([0.75, 0.375]))
    assert mean == pytest.approx(np.mean([(0.25 + 0.5 + 0.75) / 3, (0.125 + 0.25 + 0.375) / 3]))
    assert episode_return == pytest.approx(np.mean([3.0, 2.0 + 4.0 + 6.0]))
    result = evaluate_policy(RecordingPolicy(), ScriptedEnv(3), [7, 8])
    assert result.entropy_reduction.tolist() == [reduction, reduction]
    assert result.episode_length.tolist() == [3, 3]


def test_an_episode_without_agents_or_steps_is_refused() -> None:
    with pytest.raises(ValueError, match="seed 4 has no live agents after reset"):
        _episode_metrics(RecordingPolicy(), ScriptedEnv(3, agents_after_reset=()), 4)
    with pytest.raises(ValueError, match="seed 5 ended before its first step"):
        _episode_metrics(RecordingPolicy(), EndedEnv(3), 5)


def _config(**overrides: Any) -> TrainingConfig:
    settings: dict[str, Any] = {
        "n_agents": 2,
        "timesteps": 400,
        "n_envs": 1,
        "env_kwargs": TINY_ENV,
        "hyperparameters": {"n_steps": 50, "batch_size": 50, "net_arch": [8]},
        "eval_freq": 200,
        "eval_episodes": 2,
        "checkpoint_freq": 200,
    }
    settings.update(overrides)
    return TrainingConfig(**settings)


def test_the_resume_point_of_a_new_directory_is_none_and_a_foreign_run_is_refused(
    tmp_path: Path,
) -> None:
    config = _config()
    assert _resume_point(tmp_path, config) == (config, None)
    (tmp_path / "config.json").write_text(json.dumps({**config.to_json(), "algo": "sac"}))
    with pytest.raises(ValueError, match="algo='sac', this run has algo='ppo'"):
        _resume_point(tmp_path, config)


def test_only_a_fresh_run_loads_its_initial_model(tmp_path: Path) -> None:
    config = _config(init_from=str(tmp_path / "missing.zip"))
    assert _initial_model(config, (tmp_path / "model.zip", 200)) == (config, None)
    assert _initial_model(_config(), None) == (_config(), None)
    with pytest.raises(ValueError, match="no trained model"):
        _initial_model(config, None)


def test_a_run_that_already_reached_its_timesteps_reports_the_saved_model(tmp_path: Path) -> None:
    result = _already_trained(tmp_path, (tmp_path / "checkpoints" / "m.zip", 400), 0.0)
    assert result.model_path == tmp_path / "model.zip"
    assert result.resumed_from == tmp_path / "checkpoints" / "m.zip"
    assert result.start_timesteps == result.timesteps == 400
    assert result.last_evaluation is None and result.wall_seconds > 0.0


@pytest.mark.parametrize(("checkpoint_freq", "eval_freq"), [(200, 200), (0, 0)])
def test_the_callbacks_follow_the_frequencies(
    tmp_path: Path, checkpoint_freq: int, eval_freq: int
) -> None:
    config = _config(checkpoint_freq=checkpoint_freq, eval_freq=eval_freq)
    callbacks, evaluation = _training_callbacks(config, tmp_path, object(), 4, False, None)  # type: ignore[arg-type]
    assert isinstance(callbacks[0], TqdmProgressCallback) and callbacks[-1] is evaluation
    assert isinstance(evaluation, PeriodicEvaluationCallback)
    assert evaluation.eval_freq == (eval_freq or 10 * config.timesteps)
    assert evaluation.curve_path == tmp_path / "eval.csv"
    checkpoints = [c for c in callbacks if isinstance(c, PruningCheckpointCallback)]
    assert [c.save_freq for c in checkpoints] == ([checkpoint_freq // 4] if checkpoint_freq else [])


def test_a_fresh_model_starts_from_the_initial_weights_and_drops_an_old_curve(
    tmp_path: Path,
) -> None:
    config = _config(seed=1)
    vec_env = make_training_vec_env(config.env_id, config.full_env_kwargs(), n_envs=1)
    try:
        (tmp_path / "eval.csv").write_text("timesteps\n100\n")
        initial = _fresh_model(replace(config, seed=2), vec_env, tmp_path / "other", None)
        plain = _fresh_model(config, vec_env, tmp_path, None)
        started = _fresh_model(config, vec_env, tmp_path, initial)
    finally:
        vec_env.close()
    assert not (tmp_path / "eval.csv").exists()
    weights = initial.policy.state_dict()
    assert all(torch.equal(weights[k], v) for k, v in started.policy.state_dict().items())
    assert not all(torch.equal(weights[k], v) for k, v in plain.policy.state_dict().items())


def test_imitation_builds_its_policy_and_evaluation_environment(tmp_path: Path) -> None:
    config = ImitationConfig(
        n_agents=2, episode_steps=6, net_arch=(16, 16), env_kwargs={"n_particles": 100}
    )
    model, envs = _policy_model(config, tmp_path)
    eval_env = _evaluation_env(config)
    try:
        assert len(envs) == 2
        assert model.policy.net_arch == [16, 16]
        _, infos = eval_env.reset(seed=0)
        assert eval_env.unwrapped.max_cycles == 6
        assert all("belief" in info for info in infos.values())
    finally:
        for env in (*envs, eval_env):
            env.close()
