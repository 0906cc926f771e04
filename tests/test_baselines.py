"""Tests of infoseek.baselines (parameter-shared SB3 training) and ``infoseek train``."""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import infoseek.envs as envs  # noqa: E402
from infoseek.baselines import (  # noqa: E402
    TrainedPolicy,
    TrainingConfig,
    evaluate_policy,
    load_policy,
    make_training_vec_env,
    shipped_model,
    train,
)
from infoseek.baselines.features import (  # noqa: E402
    EgocentricObservationExtractor,
    ScaledObservationExtractor,
    egocentric_layout,
    observation_scaling,
)
from infoseek.baselines.training import find_resume_point  # noqa: E402
from infoseek.experiments.train import add_train_arguments, run_train  # noqa: E402
from infoseek.planners import RandomPolicy  # noqa: E402

torch.set_num_threads(1)

TINY_ENV = {"n_particles": 100, "max_cycles": 10}
TINY_HYPER = {
    "ppo": {"n_steps": 50, "batch_size": 50, "n_epochs": 2},
    "sac": {"learning_starts": 50, "batch_size": 32, "buffer_size": 2_000},
}


def tiny_config(algo: str, action_type: str, timesteps: int = 400, **overrides) -> TrainingConfig:
    settings = dict(
        algo=algo,
        n_agents=2,
        action_type=action_type,
        timesteps=timesteps,
        seed=3,
        n_envs=1,
        env_kwargs=TINY_ENV,
        hyperparameters=TINY_HYPER[algo],
        eval_freq=200,
        eval_episodes=2,
        checkpoint_freq=200,
    )
    settings.update(overrides)
    return TrainingConfig(**settings)


def tiny_env(action_type: str = "continuous", n_agents: int = 2):
    return envs.make("bearings_v0", n_agents=n_agents, action_type=action_type, **TINY_ENV)


def read_curve(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


RUNS = [("ppo", "continuous"), ("ppo", "discrete"), ("sac", "continuous")]


@pytest.fixture(scope="module")
def trained_runs(tmp_path_factory):
    """One tiny training run per (algo, action type): {(algo, type): (dir, TrainingResult)}."""
    runs = {}
    for algo, action_type in RUNS:
        out = tmp_path_factory.mktemp(f"{algo}_{action_type}")
        runs[algo, action_type] = (out, train(tiny_config(algo, action_type), out, progress=False))
    return runs


def test_a_policy_acts_in_shorter_episodes_but_not_in_longer_ones(trained_runs):
    """Position bounds grow with max_cycles: a model trained on 10-step episodes fits a 5-step
    environment (its observations lie inside the trained range), not a 40-step one."""
    out, _ = trained_runs["ppo", "continuous"]
    shorter = envs.make("bearings_v0", n_agents=2, n_particles=100, max_cycles=5)
    observations, infos = shorter.reset(seed=0)
    assert set(load_policy(out, shorter).act(observations, infos)) == set(shorter.agents)
    longer = envs.make("bearings_v0", n_agents=2, n_particles=100, max_cycles=40)
    with pytest.raises(ValueError, match="does not fit in the model's"):
        load_policy(out, longer)


@pytest.mark.parametrize(("algo", "action_type"), RUNS)
def test_training_writes_model_config_curve_and_checkpoints(trained_runs, algo, action_type):
    out, result = trained_runs[algo, action_type]
    assert result.timesteps >= 400
    assert (out / "model.zip").is_file()
    config = json.loads((out / "config.json").read_text())
    assert config["env_id"] == "bearings_v0"
    assert config["algo"] == algo
    assert config["action_type"] == action_type
    assert config["n_agents"] == 2
    assert config["seed"] == 3
    assert config["timesteps"] == 400
    assert config["trained_timesteps"] == result.timesteps
    assert config["env_kwargs"] == {**TINY_ENV, "n_agents": 2, "action_type": action_type}
    rows = read_curve(out / "eval.csv")
    steps = [int(row["timesteps"]) for row in rows]
    assert steps == sorted(steps) and len(steps) >= 2 and steps[-1] == result.timesteps
    for row in rows:
        assert 0.0 <= float(row["mean_final_posterior_mass"]) <= 1.0
        assert np.isfinite(float(row["mean_entropy_reduction"]))
    assert sorted(p.name for p in (out / "checkpoints").glob("model_*_steps.zip"))
    assert any((out / "tb").rglob("events.out.tfevents.*"))

    env = tiny_env(action_type)
    policy = load_policy(out, env)
    observations, infos = env.reset(seed=0)
    actions = policy.act(observations, infos)
    assert set(actions) == set(env.agents)
    for agent, action in actions.items():
        assert env.action_space(agent).contains(action)


@pytest.mark.parametrize(("algo", "action_type"), RUNS)
def test_loaded_model_reproduces_in_memory_evaluation(trained_runs, algo, action_type):
    """The final evaluation ran on the in-memory model; the saved one must give the same."""
    out, result = trained_runs[algo, action_type]
    rows = read_curve(out / "eval.csv")
    env = tiny_env(action_type)
    from infoseek.baselines.evaluation import evaluation_seeds

    summary = evaluate_policy(load_policy(out / "model.zip", env), env, evaluation_seeds(2))
    assert summary.summary() == pytest.approx(result.last_evaluation, rel=0, abs=1e-12)
    assert float(rows[-1]["mean_posterior_mass"]) == pytest.approx(
        summary.summary()["mean_posterior_mass"], abs=1e-12
    )


def test_save_load_round_trip_gives_identical_actions(trained_runs, tmp_path):
    out, _ = trained_runs["ppo", "continuous"]
    env = tiny_env()
    first = load_policy(out / "model.zip", env)
    first.model.save(tmp_path / "model.zip")
    (tmp_path / "config.json").write_text((out / "config.json").read_text())
    second = load_policy(tmp_path, env)
    rng = np.random.default_rng(0)
    space = env.observation_space("vehicle_0")
    batch = {
        f"vehicle_{k}": np.concatenate(
            [
                rng.uniform(0, 40, 2),
                rng.uniform(-3, 3, 1),
                rng.uniform(-5, 5, 2),
                rng.dirichlet(np.ones(64)),
                rng.uniform(0, 40, 2),
            ]
        ).astype(np.float32)
        for k in range(2)
    }
    assert batch["vehicle_0"].shape == space.shape
    a1, a2 = first.act(batch, {}), second.act(batch, {})
    for agent in batch:
        np.testing.assert_array_equal(a1[agent], a2[agent])
    # and the policy is not constant: different observations -> different actions
    other = {agent: obs.copy() for agent, obs in batch.items()}
    other["vehicle_0"][:2] = [35.0, 35.0]
    other["vehicle_0"][5:69] = np.eye(64)[63]
    assert not np.array_equal(first.act(other, {})["vehicle_0"], a1["vehicle_0"])


def test_evaluation_is_deterministic_under_a_seed(trained_runs):
    out, _ = trained_runs["ppo", "continuous"]
    env = tiny_env()
    policy = load_policy(out, env)
    first = evaluate_policy(policy, env, [5, 6, 7])
    second = evaluate_policy(load_policy(out, tiny_env()), tiny_env(), [5, 6, 7])
    for name in ("entropy_reduction", "final_posterior_mass", "mean_posterior_mass"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))
    other = evaluate_policy(policy, env, [8, 9, 10])
    assert not np.array_equal(first.entropy_reduction, other.entropy_reduction)


def test_stochastic_actions_reproducible_with_seed(trained_runs):
    out, _ = trained_runs["ppo", "continuous"]
    env = tiny_env()
    observations, infos = env.reset(seed=1)
    torch_state = torch.get_rng_state()
    draws = []
    for seed in (4, 4, 5):
        policy = load_policy(out, env, seed=seed, deterministic=False)
        draws.append([policy.act(observations, infos)["vehicle_0"][0] for _ in range(5)])
    assert draws[0] == draws[1]
    assert draws[0] != draws[2]
    assert torch.equal(torch_state, torch.get_rng_state())  # global torch RNG untouched


def test_training_is_reproducible_under_a_seed(tmp_path):
    config = tiny_config("ppo", "discrete", timesteps=200, eval_freq=0, checkpoint_freq=0)
    a = train(config, tmp_path / "a", progress=False)
    b = train(config, tmp_path / "b", progress=False)
    pa = load_policy(a.model_path).model.policy.state_dict()
    pb = load_policy(b.model_path).model.policy.state_dict()
    for key in pa:
        assert torch.equal(pa[key], pb[key]), key


def test_space_mismatch_raises_value_error(trained_runs):
    out, _ = trained_runs["ppo", "continuous"]
    with pytest.raises(ValueError, match="observation space"):
        load_policy(out, tiny_env(n_agents=3))
    with pytest.raises(ValueError, match="action space"):
        load_policy(out, tiny_env("discrete"))
    with pytest.raises(ValueError, match="no trained model"):
        load_policy(out / "missing")


def test_resume_continues_from_newest_checkpoint(tmp_path):
    config = tiny_config("ppo", "continuous", timesteps=200, eval_freq=100, checkpoint_freq=100)
    first = train(config, tmp_path, progress=False)
    assert first.timesteps == 200 and first.resumed_from is None
    # a rerun with the same total does nothing
    again = train(config, tmp_path, progress=False)
    assert again.timesteps == 200 and again.last_evaluation is None
    longer = dataclass_replace(config, timesteps=400)
    resumed = train(longer, tmp_path, progress=False)
    assert resumed.resumed_from is not None
    assert resumed.start_timesteps == 200
    assert resumed.timesteps == 400
    steps = [int(row["timesteps"]) for row in read_curve(tmp_path / "eval.csv")]
    assert steps == sorted(set(steps)) and steps[-1] == 400 and 200 in steps
    assert find_resume_point(tmp_path)[1] == 400
    with pytest.raises(ValueError, match="algo"):
        train(
            dataclass_replace(config, algo="sac", hyperparameters=TINY_HYPER["sac"]),
            tmp_path,
            progress=False,
        )


def test_resume_refuses_hyperparameters_it_would_not_use(tmp_path):
    """Resuming continues with the saved model's hyperparameters: a different --hyper value is
    refused (config.json untouched), and a resume without --hyper records the saved values."""
    config = tiny_config("ppo", "continuous", timesteps=100, eval_freq=0, checkpoint_freq=100)
    train(config, tmp_path, progress=False)
    saved = (tmp_path / "config.json").read_bytes()
    changed = {**TINY_HYPER["ppo"], "gamma": 0.5}
    longer = dataclass_replace(config, timesteps=200, hyperparameters=changed)
    with pytest.raises(ValueError, match=r"gamma=0\.95.*--hyper gamma=0\.5"):
        train(longer, tmp_path, progress=False)
    assert (tmp_path / "config.json").read_bytes() == saved
    # a resume that names no hyperparameter keeps (and records) the saved ones
    recorded = json.loads(saved)
    recorded["hyperparameters"]["ent_coef"] = 0.25  # as if the defaults had changed since
    (tmp_path / "config.json").write_text(json.dumps(recorded))
    train(dataclass_replace(config, timesteps=200, hyperparameters={}), tmp_path, progress=False)
    after = json.loads((tmp_path / "config.json").read_text())
    assert after["hyperparameters"] == recorded["hyperparameters"]
    assert after["trained_timesteps"] == 200


@pytest.mark.parametrize(
    ("hyper", "message"),
    [
        ({"n_steps": "abc"}, "n_steps must be an integer, got 'abc'"),
        ({"n_steps": 0}, r"n_steps must lie in \[1, inf\]"),
        ({"gamma": 2}, r"gamma must lie in \[0.0, 1.0\]"),
        ({"gamma": True}, "gamma must be a number"),
        ({"learning_rate": "fast"}, "learning_rate must be a number or"),
        ({"net_arch": [64, 0]}, "net_arch must be a list of integers >= 1"),
        ({"net_arch": 64}, "net_arch must be a list"),
        ({"normalize_advantage": 1}, "normalize_advantage must be true/false"),
        ({"target_kl": "x"}, "target_kl must be a number or None"),
    ],
)
def test_every_hyperparameter_is_type_checked_before_anything_is_written(hyper, message, tmp_path):
    with pytest.raises((TypeError, ValueError), match=message):
        train(tiny_config("ppo", "continuous", hyperparameters=hyper), tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_tuple_hyperparameters_are_accepted_from_json_lists():
    config = tiny_config(
        "sac", "continuous", hyperparameters={**TINY_HYPER["sac"], "train_freq": [2, "step"]}
    )
    assert config.hyperparameters["train_freq"] == (2, "step")
    with pytest.raises(TypeError, match="train_freq must be an integer or"):
        tiny_config("sac", "continuous", hyperparameters={"train_freq": [2, 3]})


def dataclass_replace(config: TrainingConfig, **changes) -> TrainingConfig:
    import dataclasses

    return dataclasses.replace(config, **changes)


def test_config_validation():
    with pytest.raises(ValueError, match="continuous"):
        TrainingConfig(algo="sac", action_type="discrete")
    with pytest.raises(ValueError, match="algo"):
        TrainingConfig(algo="dqn")
    with pytest.raises(ValueError, match="hyperparameter"):
        TrainingConfig(algo="ppo", hyperparameters={"buffer_size": 10})
    with pytest.raises(ValueError, match="env_kwargs"):
        TrainingConfig(env_kwargs={"n_agents": 3})
    with pytest.raises(ValueError, match="features"):
        TrainingConfig(features="pixels")


def test_training_vec_env_filters_infos_and_marks_truncation():
    venv = make_training_vec_env("bearings_v0", {**TINY_ENV, "n_agents": 2}, n_envs=2)
    assert venv.num_envs == 4
    venv.seed(0)
    observations = venv.reset()
    assert observations.shape == (4, 71)
    returns = np.zeros(4)
    for step in range(TINY_ENV["max_cycles"]):
        observations, rewards, dones, infos = venv.step(np.zeros((4, 1), np.float32))
        for info in infos:
            assert "belief" not in info and "vehicle_states" not in info
            assert 0.0 <= info["posterior_mass"] <= 1.0
            assert info["TimeLimit.truncated"] == (step == TINY_ENV["max_cycles"] - 1)
            assert ("episode" in info) == (step == TINY_ENV["max_cycles"] - 1)
        returns += rewards
    assert dones.all()
    for k, info in enumerate(infos):
        assert info["episode"]["l"] == TINY_ENV["max_cycles"]
        assert info["episode"]["r"] == pytest.approx(returns[k], rel=1e-5)
    venv.close()


def test_seeded_vec_env_is_reproducible_and_copies_differ():
    def rollout():
        venv = make_training_vec_env("bearings_v0", {**TINY_ENV, "n_agents": 2}, n_envs=2)
        venv.seed(11)
        venv.reset()
        rewards = [venv.step(np.full((4, 1), 0.3, np.float32))[1] for _ in range(4)]
        venv.close()
        return np.array(rewards)

    first, second = rollout(), rollout()
    np.testing.assert_array_equal(first, second)
    assert not np.array_equal(first[:, :2], first[:, 2:])  # copies get different seeds


def test_observation_scaling_maps_domain_to_unit_box():
    env = envs.make("bearings_v0", n_agents=3)
    offset, scale = observation_scaling(env)
    extractor = ScaledObservationExtractor(env.observation_space("vehicle_0"), offset, scale)
    layout = env.unwrapped.config.observation_layout
    corner = np.zeros((2, 73), np.float32)
    corner[0, 0:2] = [0.0, 0.0]
    corner[1, 0:2] = [40.0, 40.0]
    corner[0, 2], corner[1, 2] = -np.pi, np.pi
    corner[:, layout["belief_grid"]] = [[0.0], [1.0]]
    corner[0, layout["mmse_estimate"]] = [0.0, 0.0]
    corner[1, layout["mmse_estimate"]] = [40.0, 40.0]
    corner[1, layout["others_relative_positions"]] = 20.0
    features = extractor(torch.as_tensor(corner)).numpy()
    keep = np.r_[0:3, layout["belief_grid"], layout["mmse_estimate"]]
    np.testing.assert_allclose(features[0, keep], -1.0, atol=1e-6)
    np.testing.assert_allclose(features[1, keep], 1.0, atol=1e-6)
    np.testing.assert_allclose(features[1, layout["others_relative_positions"]], 1.0, atol=1e-6)
    np.testing.assert_allclose(features[0, layout["others_relative_positions"]], 0.0, atol=1e-6)
    with pytest.raises(ValueError, match="scale"):
        ScaledObservationExtractor(env.observation_space("vehicle_0"), offset, [0.0] * len(scale))


def _egocentric_by_hand(observation: np.ndarray, layout: dict, n_agents: int) -> np.ndarray:
    """The appended egocentric entries of one observation, written out per entry."""
    x, y, heading = (float(v) for v in observation[:3])
    half = 20.0
    c, s = np.cos(heading), np.sin(heading)

    def body(dx: float, dy: float) -> list[float]:  # rotate by -heading, then scale
        return [(c * dx + s * dy) / half, (-s * dx + c * dy) / half]

    ex, ey = observation[layout["mmse_estimate"]]
    entries = [c, s, *body(ex - x, ey - y), np.hypot(ex - x, ey - y) / np.hypot(half, half)]
    others = observation[layout["others_relative_positions"]].reshape(n_agents - 1, 2)
    for dx, dy in others:
        entries += body(dx, dy)
    entries += [1.0 / (1.0 + np.hypot(dx, dy)) for dx, dy in others]
    entries += body(20.0 - x, 20.0 - y)
    masses = observation[layout["belief_grid"]].reshape(8, 8)
    masses = masses / masses.sum()
    centres = (np.arange(8) + 0.5) * 5.0
    mass_x, mass_y = masses.sum(axis=1), masses.sum(axis=0)
    for marginal in (mass_x, mass_y):
        mean = marginal @ centres
        entries.append(np.sqrt(marginal @ (centres - mean) ** 2) / half)
    return np.array(entries)


def _egocentric_extractor(n_agents: int, n_particles: int, **env_kwargs):
    """``(env, extractor, observation layout)`` for a ``bearings_v0`` of ``n_agents``."""
    env = envs.make("bearings_v0", n_agents=n_agents, n_particles=n_particles, **env_kwargs)
    offset, scale = observation_scaling(env)
    extractor = EgocentricObservationExtractor(
        env.observation_space("vehicle_0"), offset, scale, egocentric_layout(env)
    )
    return env, extractor, env.unwrapped.config.observation_layout


def _observations_along_random_episodes(env, rng, max_steps: int) -> np.ndarray:
    """Every agent's float32 observation after ``0 .. max_steps - 1`` random steps of the
    episodes seeded 0 .. 3, stacked."""
    observations = []
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        for _ in range(rng.integers(0, max_steps)):
            obs, *_ = env.step({a: rng.uniform(-0.5, 0.5, size=1) for a in env.agents})
        observations += list(obs.values())
    return np.stack(observations).astype(np.float32)


def test_egocentric_features_match_hand_computation():
    env, extractor, layout = _egocentric_extractor(3, 300)
    offset, scale = observation_scaling(env)
    batch = _observations_along_random_episodes(env, np.random.default_rng(5), 6)
    features = extractor(torch.as_tensor(batch)).numpy()
    assert features.shape == (len(batch), extractor.features_dim)
    scaled = ScaledObservationExtractor(env.observation_space("vehicle_0"), offset, scale)
    np.testing.assert_allclose(features[:, :73], scaled(torch.as_tensor(batch)).numpy())
    for observation, row in zip(batch, features, strict=True):
        expected = _egocentric_by_hand(observation.astype(np.float64), layout, 3)
        np.testing.assert_allclose(row[73:], expected, atol=2e-5)


def _moment_features_by_hand(observation: np.ndarray, layout: dict) -> np.ndarray:
    """The six ``belief_moments`` features of one observation, written out per entry."""
    x, y, heading = (float(v) for v in observation[:3])
    sx, sy, rho = (float(v) for v in observation[layout["belief_moments"]][:3])
    covariance = np.array([[sx * sx, rho * sx * sy], [rho * sx * sy, sy * sy]])
    forward = np.array([np.cos(heading), np.sin(heading)])
    left = np.array([-np.sin(heading), np.cos(heading)])
    offset = observation[layout["mmse_estimate"]].astype(np.float64) - [x, y]
    distance = max(float(np.hypot(*offset)), 1e-6)
    along = offset / distance
    across = np.array([-along[1], along[0]])
    spread = {
        name: np.sqrt(max(float(u @ covariance @ u), 0.0))
        for name, u in (("f", forward), ("l", left), ("a", along), ("c", across))
    }
    correlation = (forward @ covariance @ left) / max(spread["f"] * spread["l"], 1e-12)
    return np.log(
        [spread["f"] + 0.01, spread["l"] + 0.01, np.exp(np.clip(correlation, -1, 1))]
        + [spread["a"] + 0.01, spread["c"] + 0.01, spread["c"] / distance + 0.01]
    )


def test_egocentric_moment_features_match_hand_computation():
    """The body-frame covariance features of ``belief_moments`` observations (the shipped
    policy's), including an estimate on the vehicle and a degenerate covariance."""
    env, extractor, layout = _egocentric_extractor(3, 300, belief_moments=True)
    batch = _observations_along_random_episodes(env, np.random.default_rng(8), 8)
    batch[0, layout["mmse_estimate"]] = batch[0, 0:2]  # the estimate where the vehicle is
    moments = layout["belief_moments"].start  # (s_x, s_y, rho, mass)
    batch[1, moments : moments + 3] = [0.0, 0.0, 0.0]
    batch[2, moments : moments + 3] = [1.5, 0.2, -1.0]  # a rank-one covariance
    features = extractor(torch.as_tensor(batch)).numpy()
    plain = _egocentric_extractor(3, 300)[1]
    assert features.shape[1] == plain.features_dim + 4 + 6  # the block scaled, then features
    for observation, row in zip(batch, features, strict=True):
        expected = _moment_features_by_hand(observation.astype(np.float64), layout)
        np.testing.assert_allclose(row[-6:], expected, atol=5e-5, rtol=1e-5)


_TORCH_LOGARITHM_CHECK = """
import numpy as np, torch
torch.set_num_threads(1)
rng = np.random.default_rng(3)
bits = rng.integers(0x3C23D70A, 0x7F000000, size=2_000_000, dtype=np.uint32)  # 0.01 .. 1.7e38
values = torch.from_numpy(bits.view(np.float32).copy())
whole = torch.log(values).view(torch.int32)
same = True
for length in (1, 2, 3, 4, 5, 6, 7, 8, 9, 16, 17, 20, 33):
    for start in (0, 1, 3):
        rows = values[start : start + 2000 * length].reshape(-1, length)
        parts = torch.cat([torch.log(row) for row in rows]).view(torch.int32)
        same &= bool(torch.equal(parts, whole[start : start + parts.numel()]))
        columns = torch.stack([torch.log(rows[:, k]) for k in range(length)], 1)
        same &= bool(torch.equal(columns.view(torch.int32), torch.log(rows).view(torch.int32)))
print("same" if same else "different")
"""


@pytest.mark.parametrize("pinned", [False, True], ids=["native", "pinned"])
def test_torchs_float32_log_of_an_element_depends_on_that_element_alone(
    pinned: bool, fresh_python
) -> None:
    """The egocentric extractor takes five logarithms in one ``torch.log`` call: the bits of
    five separate calls only if torch's float32 loop computes each element from that element
    alone, whatever its neighbours, its position in a vector and the batch size. Checked in
    this machine's torch and in the pinned environment of stored trials (``MKL_CBWR``,
    ``ATEN_CPU_CAPABILITY``: set before torch loads, so in a fresh interpreter)."""
    done = fresh_python(_TORCH_LOGARITHM_CHECK, pinned=pinned)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "same"


def test_egocentric_features_are_rotation_equivariant():
    """Rotating the whole scene about the vehicle leaves the body-frame entries unchanged."""
    env, extractor, layout = _egocentric_extractor(2, 100)
    offset, scale = observation_scaling(env)
    base = np.zeros(71, np.float32)
    base[0:3] = [10.0, 12.0, 0.3]
    base[layout["others_relative_positions"]] = [3.0, -1.0]
    base[layout["mmse_estimate"]] = [25.0, 18.0]
    base[layout["belief_grid"]] = 1.0 / 64
    turned = base.copy()
    angle = 1.1
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    turned[2] = 0.3 + angle
    turned[layout["others_relative_positions"]] = rotation @ [3.0, -1.0]
    turned[layout["mmse_estimate"]] = [10.0, 12.0] + rotation @ [15.0, 6.0]
    features = extractor(torch.as_tensor(np.stack([base, turned]))).numpy()
    ahead_and_others = np.r_[73:76, 76:79]  # estimate (body, distance), other (body, proximity)
    np.testing.assert_allclose(
        features[0, ahead_and_others], features[1, ahead_and_others], atol=1e-5
    )
    with pytest.raises(ValueError, match="beyond"):
        bad = {**egocentric_layout(env), "estimate_start": 70}
        EgocentricObservationExtractor(env.observation_space("vehicle_0"), offset, scale, bad)


def test_cli_train_function(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    add_train_arguments(parser)
    args = parser.parse_args(
        [
            "--algo", "ppo", "--env", "bearings_v0", "--agents", "2", "--timesteps", "100",
            "--out", str(tmp_path), "--seed", "1", "--n-envs", "1",
            "--action-type", "discrete", "--eval-freq", "0", "--checkpoint-freq", "0",
            "--eval-episodes", "1", "--particles", "100", "--env-kwarg", "max_cycles=10",
            "--hyper", "n_steps=50", "--hyper", "batch_size=50", "--no-progress",
        ]
    )  # fmt: skip
    assert run_train(args) == 0
    assert "final posterior mass" in capsys.readouterr().out
    config = json.loads((tmp_path / "config.json").read_text())
    assert config["env_kwargs"]["n_particles"] == 100
    assert config["hyperparameters"]["n_steps"] == 50
    assert isinstance(load_policy(tmp_path), TrainedPolicy)
    with pytest.raises(ValueError, match="sac"):
        bad = parser.parse_args(
            ["--algo", "sac", "--action-type", "discrete", "--timesteps", "10", "--out", "x"]
        )
        run_train(bad)


SHIPPED_HORIZON = 20
"""Steps of the comparison episodes: at the default 60 steps four random airplanes already
localise the target (mean final posterior mass 0.995 over seeds 0..49), so the final mass is
compared after 20 steps, where it still separates policies (same spaces, shorter episode)."""


def test_shipped_model_beats_random_policy():
    env = envs.make("bearings_v0", n_agents=4, max_cycles=SHIPPED_HORIZON, belief_moments=True)
    trained = evaluate_policy(load_policy(shipped_model(), env), env, range(50))
    random = evaluate_policy(RandomPolicy.from_env(env, seed=0), env, range(50))
    assert trained.final_posterior_mass.mean() > random.final_posterior_mass.mean()


@pytest.mark.parametrize(
    ("name", "setting", "env_id"),
    [
        ("dagger_bearings_v0_4agents", "bearings_pairwise", "bearings_v0"),
        ("dagger_beacon_v0_4agents", "beacon_single", "beacon_v0"),
    ],
)
def test_shipped_models_are_the_selected_seeds_of_the_study(name, setting, env_id):
    """The shipped file is byte for byte the run the learned-policy study selects."""
    from infoseek.experiments.studies.learned import read_run, run_directories, selected_run

    results = Path(__file__).resolve().parents[1] / "experiments" / "results" / "learned"
    chosen = selected_run([read_run(path) for path in run_directories(results, setting)])
    shipped = shipped_model(name)
    for file in ("model.zip", "config.json", "eval.csv"):
        assert (shipped.parent / file).read_bytes() == (chosen.path / file).read_bytes()
    env = envs.make(env_id, n_agents=4, belief_moments=True)
    policy = load_policy(shipped, env)
    observations, infos = env.reset(seed=0)
    actions = policy.act(observations, infos)
    assert all(env.action_space(a).contains(actions[a]) for a in env.agents)


def test_shipped_model_lookup():
    path = shipped_model()
    assert path.name == "model.zip"
    config = json.loads(path.with_name("config.json").read_text())
    assert (config["algo"], config["env_id"], config["n_agents"]) == ("ppo", "bearings_v0", 4)
    assert (config["trainer"], config["imitation"]["expert"]) == ("dagger", "pairwise")
    previous = json.loads(
        shipped_model("ppo_bearings_v0_4agents").with_name("config.json").read_text()
    )
    assert previous["trained_timesteps"] >= previous["timesteps"]
    with pytest.raises(ValueError, match="available"):
        shipped_model("no_such_model")


@pytest.mark.parametrize(("algo", "action_type"), RUNS)
def test_act_gives_the_actions_of_sb3_predict(trained_runs, algo, action_type):
    """``TrainedPolicy.act`` skips ``predict``'s per-call checks but not its numbers."""
    out, _ = trained_runs[algo, action_type]
    env = tiny_env(action_type)
    policy = load_policy(out / "model.zip", env)
    observations, infos = env.reset(seed=4)
    for _ in range(5):
        actions = policy.act(observations, infos)
        stacked = np.stack([observations[a] for a in observations])
        expected, _ = policy.model.predict(stacked, deterministic=True)
        got = np.stack([np.asarray(actions[a]) for a in observations]).reshape(expected.shape)
        np.testing.assert_array_equal(got, expected)
        observations, _, _, _, infos = env.step(actions)
