r"""Amortised information planning: a policy trained to act as an MI planner does.

An information planner (e.g. :class:`~infoseek.planners.PairwiseNodePlanner`) decides from
each agent's own particle belief by maximising mutual information (eq. 22); a policy network
decides from the observation alone, in a fraction of the time. :func:`train_imitation` fits
the policy to the planner's decisions:

1. **Behaviour cloning** (iteration 0): the expert drives ``episodes_per_iteration`` seeded
   episodes; every agent's observation is labelled with the expert's action for it.
2. **DAgger** (iterations ``1 .. iterations``): the episodes are driven by the expert with
   probability ``beta_i = beta_decay ** i`` per step and by the current policy otherwise
   (:mod:`infoseek.baselines.expert_rollouts`); every visited state is labelled by the expert
   from the belief the agent holds, and the labelled set grows by aggregation.

After each iteration the policy is refitted on the whole set: the Gaussian policy's mean
:math:`\mu_\phi(o)` minimises the mean squared error
:math:`\frac{1}{n}\sum_k \lVert \mu_\phi(o_k) - a^\star_k\rVert^2` over minibatches (Adam),
and its state-independent log standard deviation is set to the maximum-likelihood value
:math:`\log \sqrt{\frac1n \sum_k (\mu_\phi(o_k) - a^\star_k)^2}` per action axis, so the saved
PPO model is a well-formed stochastic policy that PPO can fine-tune on the entropy-reduction
reward (``infoseek train --algo ppo --init DIR/model.zip``). Deterministic acting uses
:math:`\mu_\phi`.

**Run directory** ``out``: ``model.zip`` (a Stable-Baselines3 PPO archive, loaded by
:func:`~infoseek.baselines.load_policy`), ``config.json`` (what :func:`train` writes, plus
``trainer: "dagger"``, the imitation settings and ``expert_evaluation``, the expert on the
same evaluation episodes), ``eval.csv`` (one row per iteration: the learner alone on seeded
evaluation episodes, the learning curve); ``iterations/`` holds the model after each
iteration while the run lasts (the workers load it to drive the next one).
"""

from __future__ import annotations

import csv
import shutil
import time
from collections.abc import Callable, Mapping
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.base_class import BaseAlgorithm

from infoseek.baselines.evaluation import evaluate_policy, evaluation_seeds
from infoseek.baselines.expert_rollouts import (
    EXPERTS,
    LabelledBatch,
    RolloutTask,
    build_expert,
    rollout_pool,
    run_rollouts,
)
from infoseek.baselines.policy import MODEL_FILE, TrainedPolicy
from infoseek.baselines.training import (
    CURVE_FILE,
    FEATURES,
    TrainingConfig,
    build_model,
    write_run_config,
)
from infoseek.baselines.vec_env import make_training_vec_env
from infoseek.envs import make, registry

__all__ = ["IMITATION_CURVE_COLUMNS", "ImitationConfig", "ImitationResult", "train_imitation"]

ITERATION_DIR = "iterations"
#: Columns of ``eval.csv``.
IMITATION_CURVE_COLUMNS = (
    "iteration",
    "beta",
    "labelled_states",
    "expert_labels_seconds",
    "wall_seconds",
    "fit_loss",
    "mean_final_posterior_mass",
    "mean_posterior_mass",
    "mean_entropy_reduction",
)


@dataclass(frozen=True)
class ImitationConfig:
    """What to train (everything ``config.json`` records).

    Attributes:
        env_id: Registered environment id.
        n_agents: Number of agents (one shared policy).
        expert: The planner imitated (:data:`~infoseek.baselines.expert_rollouts.EXPERTS`).
        iterations: DAgger iterations after the behaviour-cloning one (>= 0).
        episodes_per_iteration: Seeded episodes labelled per iteration (>= 1).
        episode_steps: Steps per episode (>= 1, at most the environment's ``max_cycles``).
        beta_decay: ``beta_i = beta_decay ** i`` (in ``[0, 1)``).
        epochs: Passes over the aggregated set per iteration (>= 1).
        batch_size: Minibatch size of the fit (>= 1).
        learning_rate: Adam step size (> 0).
        net_arch: Hidden layer sizes of the policy (and value) network.
        features: ``"egocentric"`` or ``"scaled"`` (:mod:`infoseek.baselines.features`).
        seed: Seed of the network, the episodes and the minibatch order.
        num_cpus: Worker processes for the labelled episodes (0: in this process).
        eval_episodes: Seeded learner-only episodes after each iteration (>= 1).
        env_kwargs: Further environment keywords (``n_agents`` and ``action_type`` are fields).
    """

    env_id: str = "bearings_v0"
    n_agents: int = 4
    expert: str = "pairwise"
    iterations: int = 6
    episodes_per_iteration: int = 32
    episode_steps: int = 40
    beta_decay: float = 0.5
    epochs: int = 20
    batch_size: int = 256
    learning_rate: float = 1e-3
    net_arch: tuple[int, ...] = (128, 128)
    features: str = "egocentric"
    seed: int = 0
    num_cpus: int = 0
    eval_episodes: int = 50
    env_kwargs: Mapping[str, Any] = field(default_factory=lambda: {"belief_moments": True})

    def __post_init__(self) -> None:
        if self.env_id not in registry:
            raise ValueError(f"env_id must be one of {sorted(registry)}, got {self.env_id!r}")
        if self.expert not in EXPERTS:
            raise ValueError(f"expert must be one of {sorted(EXPERTS)}, got {self.expert!r}")
        if self.features not in FEATURES:
            raise ValueError(f"features must be one of {list(FEATURES)}, got {self.features!r}")
        for name, minimum in (
            ("n_agents", 1),
            ("iterations", 0),
            ("episodes_per_iteration", 1),
            ("episode_steps", 1),
            ("epochs", 1),
            ("batch_size", 1),
            ("seed", 0),
            ("num_cpus", 0),
            ("eval_episodes", 1),
        ):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
                raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
        if not 0.0 <= float(self.beta_decay) < 1.0:
            raise ValueError(f"beta_decay must lie in [0, 1), got {self.beta_decay!r}")
        if not float(self.learning_rate) > 0.0:
            raise ValueError(f"learning_rate must be > 0, got {self.learning_rate!r}")
        arch = tuple(self.net_arch)
        if not arch or any(isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in arch):
            raise ValueError(f"net_arch must be positive integers, got {self.net_arch!r}")
        clashes = {"n_agents", "action_type", "belief_in_infos"} & set(self.env_kwargs)
        if clashes:
            raise ValueError(f"env_kwargs must not set {sorted(clashes)}")
        object.__setattr__(self, "net_arch", arch)
        object.__setattr__(self, "env_kwargs", dict(self.env_kwargs))

    def full_env_kwargs(self) -> dict[str, Any]:
        """Environment keywords including ``n_agents`` and ``action_type="continuous"``."""
        return {**self.env_kwargs, "n_agents": self.n_agents, "action_type": "continuous"}

    def training_config(self) -> TrainingConfig:
        """The PPO run this policy is saved as (what ``config.json`` and a fine-tune read)."""
        return TrainingConfig(
            algo="ppo",
            env_id=self.env_id,
            n_agents=self.n_agents,
            seed=self.seed,
            n_envs=1,
            env_kwargs=self.env_kwargs,
            hyperparameters={"net_arch": list(self.net_arch)},
            features=self.features,
        )

    def check_environment(self) -> None:
        """Build the environment and the expert once, so that a setting either cannot serve
        (e.g. ``expert="joint"`` for too many agents) fails before any work.

        Raises:
            ValueError: The environment or the expert refuses the settings (their message).
        """
        env = make(self.env_id, **{**self.full_env_kwargs(), "belief_in_infos": True})
        try:
            if self.episode_steps > env.unwrapped.max_cycles:
                raise ValueError(
                    f"episode_steps={self.episode_steps} exceeds the environment's max_cycles "
                    f"({env.unwrapped.max_cycles})"
                )
            build_expert(self.expert, env, seed=0)
        finally:
            env.close()


@dataclass(frozen=True)
class ImitationResult:
    """Outcome of :func:`train_imitation`.

    Attributes:
        model_path: ``out/model.zip``.
        config_path: ``out/config.json``.
        curve_path: ``out/eval.csv``.
        labelled_states: Agent states in the aggregated set.
        wall_seconds: Wall time of the run.
        last_evaluation: Means of the last evaluation.
    """

    model_path: Path
    config_path: Path
    curve_path: Path
    labelled_states: int
    wall_seconds: float
    last_evaluation: dict[str, float]


def _episode_seeds(config: ImitationConfig, iteration: int) -> tuple[int, ...]:
    """Distinct seeds per run seed and iteration, apart from the evaluation seeds."""
    base = 10_000_000 + config.seed * 100_000 + iteration * config.episodes_per_iteration
    return tuple(base + k for k in range(config.episodes_per_iteration))


def fit_policy(
    model: BaseAlgorithm, data: LabelledBatch, config: ImitationConfig, rng: np.random.Generator
) -> float:
    """Fit ``model``'s Gaussian policy to ``data`` (module docstring); returns the last
    epoch's mean squared error."""
    policy: Any = model.policy
    policy.set_training_mode(True)
    optimizer = torch.optim.Adam(
        [p for name, p in policy.named_parameters() if not name.startswith(("value", "log_std"))],
        lr=float(config.learning_rate),
    )
    observations = torch.as_tensor(data.observations)
    targets = torch.as_tensor(data.actions)
    n = observations.shape[0]
    loss_value = float("nan")
    for _ in range(config.epochs):
        order = torch.as_tensor(rng.permutation(n))
        total = 0.0
        for start in range(0, n, config.batch_size):
            index = order[start : start + config.batch_size]
            loss = torch.mean((_policy_mean(policy, observations[index]) - targets[index]) ** 2)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += float(loss.detach()) * index.numel()
        loss_value = total / n
    policy.set_training_mode(False)
    with torch.no_grad():
        residual = _policy_mean(policy, observations) - targets
        rms = torch.sqrt(torch.mean(residual**2, dim=0)).clamp_min(1e-3)
        policy.log_std.copy_(torch.log(rms))
    return loss_value


def _policy_mean(policy: Any, observations: torch.Tensor) -> torch.Tensor:
    features = policy.extract_features(observations, policy.pi_features_extractor)
    return policy.action_net(policy.mlp_extractor.forward_actor(features))


def _labelled_episodes(
    config: ImitationConfig, iteration: int, out: Path, pool: ProcessPoolExecutor | None
) -> tuple[LabelledBatch, float]:
    """The expert-labelled episodes of ``iteration`` and their ``beta`` (module docstring):
    the expert drives at iteration 0, the model saved after the previous iteration with
    probability ``1 - beta`` per step afterwards."""
    beta = 1.0 if iteration == 0 else config.beta_decay**iteration
    learner = None if iteration == 0 else str(out / ITERATION_DIR / f"{iteration - 1}.zip")
    task = RolloutTask(
        env_id=config.env_id,
        env_kwargs=config.full_env_kwargs(),
        expert=config.expert,
        model_path=learner,
        beta=beta,
        seeds=_episode_seeds(config, iteration),
        steps=config.episode_steps,
    )
    return run_rollouts(task, config.num_cpus, pool), beta


def _write_curve_row(path: Path, row: Mapping[str, float]) -> None:
    new = not path.is_file()
    with path.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=IMITATION_CURVE_COLUMNS)
        if new:
            writer.writeheader()
        writer.writerow({k: row[k] for k in IMITATION_CURVE_COLUMNS})


def _policy_model(config: ImitationConfig, out: Path) -> tuple[BaseAlgorithm, list[Any]]:
    """The PPO model to fit, built as :func:`~infoseek.baselines.training.train` builds it
    (TensorBoard logs under ``out``), and the environments it was built on (to close)."""
    vec_env = make_training_vec_env(config.env_id, config.full_env_kwargs(), n_envs=1)
    probe = make(config.env_id, **config.full_env_kwargs())
    return build_model(config.training_config(), vec_env, probe, out), [vec_env, probe]


def _evaluation_env(config: ImitationConfig) -> Any:
    """The environment of the evaluation episodes: ``episode_steps`` long, beliefs in the
    infos (the expert plans from them)."""
    eval_kwargs = {**config.full_env_kwargs(), "max_cycles": config.episode_steps}
    return make(config.env_id, **eval_kwargs, belief_in_infos=True)


def train_imitation(
    config: ImitationConfig,
    out: str | Path,
    *,
    on_iteration: Callable[[Mapping[str, float]], None] | None = None,
) -> ImitationResult:
    """Behaviour cloning then DAgger (module docstring) into the run directory ``out``.

    Args:
        config: What to train.
        out: Run directory (created; an existing ``eval.csv`` is replaced).
        on_iteration: Called with each ``eval.csv`` row.

    Raises:
        ValueError: Settings the environment or the expert cannot serve (before any work).
    """
    start = time.perf_counter()
    config.check_environment()
    out = Path(out)
    torch.manual_seed(config.seed)
    rng = np.random.default_rng([config.seed, 4201])
    model, model_envs = _policy_model(config, out)
    (out / ITERATION_DIR).mkdir(parents=True, exist_ok=True)
    curve_path = out / CURVE_FILE
    curve_path.unlink(missing_ok=True)
    eval_env = _evaluation_env(config)
    seeds = evaluation_seeds(config.eval_episodes)
    expert = build_expert(config.expert, eval_env, seed=config.seed)
    expert_evaluation = evaluate_policy(expert, eval_env, seeds).summary()
    pool = rollout_pool(config.num_cpus)
    data: LabelledBatch | None = None
    expert_seconds, row = 0.0, {}
    try:
        for iteration in range(config.iterations + 1):
            batch, beta = _labelled_episodes(config, iteration, out, pool)
            expert_seconds += batch.expert_seconds
            data = batch if data is None else LabelledBatch.concatenate([data, batch])
            loss = fit_policy(model, data, config, rng)
            model.save(str(out / ITERATION_DIR / f"{iteration}.zip"))
            evaluation = evaluate_policy(TrainedPolicy(model), eval_env, seeds).summary()
            row = {
                "iteration": iteration,
                "beta": beta,
                "labelled_states": data.observations.shape[0],
                "expert_labels_seconds": expert_seconds,
                "wall_seconds": time.perf_counter() - start,
                "fit_loss": loss,
                **evaluation,
            }
            _write_curve_row(curve_path, row)
            if on_iteration is not None:
                on_iteration(row)
    finally:
        if pool is not None:
            pool.shutdown()
        for env in (*model_envs, eval_env):
            env.close()
    assert data is not None  # at least the cloning iteration ran
    return _finish_run(config, out, model, data, row, expert_evaluation, start)


def _finish_run(
    config: ImitationConfig,
    out: Path,
    model: BaseAlgorithm,
    data: LabelledBatch,
    row: Mapping[str, float],
    expert_evaluation: Mapping[str, float],
    start: float,
) -> ImitationResult:
    """Save the final ``model`` and ``config.json`` (with the imitation record) in ``out``,
    remove the per-iteration models, and return the result (``row``: the last curve row)."""
    model.save(str(out / MODEL_FILE))
    shutil.rmtree(out / ITERATION_DIR)
    wall = time.perf_counter() - start
    extra = {
        "trainer": "dagger",
        "imitation": {**asdict(config), "net_arch": list(config.net_arch)},
        "labelled_states": int(data.observations.shape[0]),
        "wall_seconds": wall,
        "expert_evaluation": expert_evaluation,
    }
    config_path = write_run_config(out, config.training_config(), 0, extra)
    return ImitationResult(
        model_path=out / MODEL_FILE,
        config_path=config_path,
        curve_path=out / CURVE_FILE,
        labelled_states=int(data.observations.shape[0]),
        wall_seconds=wall,
        last_evaluation={k: float(v) for k, v in row.items()},
    )
