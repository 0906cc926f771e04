"""Smoke runs of the framework recipes in examples/ and of the BenchMARL task.

Each recipe is loaded from its file (examples/ is not a package) and run at smoke size through
its public functions; a test is skipped when its framework is not installed (``.ci/frameworks``
installs them all).
"""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import infoseek.envs

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SMALL = {"n_agents": 2, "n_particles": 200}


def load_example(name: str) -> ModuleType:
    """Import ``examples/<name>.py`` as a module (registered, so dataclasses resolve)."""
    module_name = f"infoseek_example_{name}"
    if module_name in sys.modules:
        return sys.modules[module_name]
    spec = importlib.util.spec_from_file_location(module_name, EXAMPLES / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[module_name]
        raise
    return module


@pytest.fixture(autouse=True)
def _one_torch_thread() -> Iterator[None]:
    """One torch thread, as the recipes' main() sets it; the worker's setting comes back after."""
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def test_every_recipe_has_a_main_and_a_docstring() -> None:
    scripts = sorted(path.stem for path in EXAMPLES.glob("*.py"))
    assert scripts == [
        "benchmarl_mappo",
        "rllib_ppo",
        "sb3_ppo",
        "tianshou_collect",
        "torchrl_check",
    ]
    for script in scripts:
        text = (EXAMPLES / f"{script}.py").read_text(encoding="utf-8")
        assert text.startswith('"""'), script
        assert "def main(argv: list[str] | None = None) -> int:" in text, script
        assert 'if __name__ == "__main__":\n    raise SystemExit(main())' in text, script
        assert "--smoke" in text, script


def test_sb3_ppo_trains_the_shared_and_the_single_vehicle_forms() -> None:
    pytest.importorskip("stable_baselines3")
    recipe = load_example("sb3_ppo")
    shared = recipe.train_shared(
        timesteps=256, n_envs=2, n_steps=32, max_cycles=20, eval_episodes=2, **SMALL
    )
    assert shared.timesteps == 256
    assert shared.n_slots == 2 * SMALL["n_agents"]  # one VecEnv slot per agent per copy
    assert len(shared.returns) == 2 and all(math.isfinite(r) for r in shared.returns)
    single = recipe.train_single(timesteps=256, n_steps=128, max_cycles=20, eval_episodes=2)
    assert single.timesteps == 256
    assert single.n_slots == 1
    assert len(single.returns) == 2 and all(math.isfinite(r) for r in single.returns)


@pytest.mark.ray
def test_rllib_ppo_runs_one_iteration_through_the_shared_module() -> None:
    pytest.importorskip("ray.rllib")
    recipe = load_example("rllib_ppo")
    run = recipe.train(
        iterations=1,
        batch_size=100,
        minibatch_size=100,
        num_epochs=1,
        max_cycles=20,
        torch_threads=1,
        **SMALL,
    )
    assert run.iterations == 1 and len(run.iteration_seconds) == 1
    assert run.torch_threads == 1
    assert run.env_steps == 100  # RLlib's batch counts team steps
    assert run.agent_steps == 100 * SMALL["n_agents"]
    assert run.module_steps == {"shared": run.agent_steps}
    assert math.isfinite(run.episode_return_mean)


@pytest.mark.parametrize(
    ("env_id", "action_type"),
    [("bearings_v0", "continuous"), ("bearings_v0", "discrete"), ("beacon_v0", "continuous")],
)
def test_torchrl_specs_and_rollout_match_the_env_spaces(env_id: str, action_type: str) -> None:
    pytest.importorskip("torchrl")
    recipe = load_example("torchrl_check")
    steps, n_agents = 5, SMALL["n_agents"]
    result = recipe.check(env_id, action_type=action_type, steps=steps, max_cycles=20, **SMALL)
    env = infoseek.envs.make(env_id, action_type=action_type, **SMALL)
    assert result.steps == steps
    assert result.env_observation_shape == env.observation_space("vehicle_0").shape
    assert result.observation_shape == (steps, n_agents, *result.env_observation_shape)
    assert result.env_state_shape == env.state_space.shape
    assert result.state_shape == (steps, *env.state_space.shape)
    assert result.state_matches_env
    assert set(result.info_shapes) == set(result.env_info_shapes)
    for key, shape in result.info_shapes.items():
        assert shape == (steps, n_agents, *result.env_info_shapes[key]), key
    action_shape = env.action_space("vehicle_0").shape
    assert result.action_shape == (steps, n_agents, *action_shape)
    assert math.isfinite(result.total_reward)


def test_torchrl_recipe_main_runs_at_smoke_size(capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("torchrl")
    assert load_example("torchrl_check").main(["--smoke"]) == 0
    output = capsys.readouterr().out
    assert output.count("check_env_specs passed") == 2  # continuous and discrete


@pytest.mark.parametrize("env_id", ["bearings_v0", "beacon_v0"])
@pytest.mark.parametrize("continuous", [True, False])
def test_benchmarl_task_declares_the_env_state_as_its_state(env_id: str, continuous: bool) -> None:
    pytest.importorskip("benchmarl")
    from infoseek.baselines.benchmarl_task import InfoseekTask

    task = InfoseekTask[env_id.upper()].get_task({"max_cycles": 7, **SMALL})
    env = task.get_env_fun(1, continuous, 0, "cpu")()
    reference = infoseek.envs.make(
        env_id, action_type="continuous" if continuous else "discrete", **SMALL
    )
    assert task.max_steps(env) == 7
    assert task.group_map(env) == {"vehicle": ["vehicle_0", "vehicle_1"]}
    state_spec = task.state_spec(env)
    assert list(state_spec.keys()) == ["state"]
    assert tuple(state_spec["state"].shape) == reference.state_space.shape
    observation = task.observation_spec(env)["vehicle", "observation"]
    assert tuple(observation.shape) == (2, *reference.observation_space("vehicle_0").shape)
    assert "state" not in task.observation_spec(env).keys()
    assert "state" not in task.info_spec(env).keys()
    assert set(task.info_spec(env)["vehicle", "info"].keys()) == set(
        reference.reset(seed=0)[1]["vehicle_0"]
    )
    action = task.action_spec(env)["vehicle", "action"]
    assert tuple(action.shape) == (2, *reference.action_space("vehicle_0").shape)


def test_benchmarl_task_defaults_and_errors() -> None:
    pytest.importorskip("benchmarl")
    from infoseek.baselines.benchmarl_task import InfoseekTask, InfoseekTaskClass

    task = InfoseekTask.BEACON_V0.get_task()
    assert task.config == {} and task.env_id == "beacon_v0"
    assert task.max_steps(None) == infoseek.envs.registry["beacon_v0"].kwargs["max_cycles"]
    with pytest.raises(ValueError, match="action_type"):
        InfoseekTask.BEARINGS_V0.get_task({"action_type": "discrete"})
    with pytest.raises(ValueError, match="unknown infoseek task"):
        InfoseekTaskClass("nope_v0", {})


def test_importing_the_baselines_does_not_import_benchmarl() -> None:
    code = "import sys, infoseek.baselines; assert 'benchmarl' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


@pytest.mark.parametrize(
    ("algorithm", "critic_in_keys"),
    [
        ("mappo", ("state",)),
        ("ippo", (("vehicle", "observation"),)),
    ],
)
def test_benchmarl_recipe_trains_and_the_mappo_critic_reads_the_state(
    algorithm: str, critic_in_keys: tuple[object, ...], tmp_path: Path
) -> None:
    pytest.importorskip("benchmarl")
    recipe = load_example("benchmarl_mappo")
    run = recipe.train(
        algorithm=algorithm,
        iterations=2,
        frames_per_batch=80,
        n_envs=2,
        minibatch_size=40,
        minibatch_iters=1,
        max_cycles=20,
        save_folder=tmp_path,
        **SMALL,
    )
    env = infoseek.envs.make("bearings_v0", **SMALL)
    assert run.iterations == 2
    assert run.frames == 2 * 80
    assert run.state_shape == env.state_space.shape
    assert run.critic_in_keys == critic_in_keys
    assert math.isfinite(run.mean_return)


def test_tianshou_collects_the_requested_episodes() -> None:
    pytest.importorskip("tianshou")
    recipe = load_example("tianshou_collect")
    max_cycles, n_agents = 5, SMALL["n_agents"]
    result = recipe.collect(n_episodes=3, n_envs=2, max_cycles=max_cycles, **SMALL)
    # AEC: one Tianshou step is one agent's turn, so an episode has n_agents * max_cycles.
    assert result.n_episodes == 3
    assert result.episode_lengths == [n_agents * max_cycles] * 3
    assert result.n_steps == 3 * n_agents * max_cycles
    assert result.returns.shape == (3, n_agents)
    assert np.isfinite(result.returns).all()
