"""Parameter-shared RL training of one policy for all agents (PPO, SAC, TD3 via SB3).

One Stable-Baselines3 model is trained on the transitions of every agent of ``n_envs`` copies
of the environment, stepped at once by the batched vector env
(:func:`infoseek.baselines.vec_env.make_training_vec_env`, i.e. :func:`infoseek.baselines.make_vec`;
``num_cpus >= 2`` splits the copies over worker processes); the reward is the
environment's own per-agent entropy reduction ``H_{t-1} - H_t`` minus the separation penalty.
A *timestep* is one agent transition, so an episode of ``T`` steps with ``A`` agents counts
``T * A`` timesteps. PPO works with both action types; SAC and TD3 need
``action_type="continuous"``. Observations are scaled by fixed constants inside the network and,
by default (``features="egocentric"``), extended with body-frame geometry: the direction and
distance of the own estimate and of the team-mates seen from the vehicle's own heading
(:mod:`infoseek.baselines.features`; ``features="scaled"`` keeps only the scaling).

**Run directory** ``out``::

    config.json            env id + keywords, algo, action type, n_agents, seed, timesteps,
                           hyperparameters, trained_timesteps (written at start and at the end)
    model.zip              the final model (load with infoseek.baselines.load_policy)
    eval.csv               the training curve: one row per evaluation (CURVE_COLUMNS)
    checkpoints/           model_<timesteps>_steps.zip (+ the newest replay buffer, off-policy)
    tb/                    TensorBoard logs (rollout/, train/, eval/ scalars)

**Resuming.** Rerunning :func:`train` with the same ``out`` (and the same algorithm,
environment, agents and action type; anything else raises ``ValueError``) continues from the
newest of the checkpoints and ``model.zip``: the model (and the replay buffer, off-policy) is
loaded, its ``num_timesteps`` kept, and training continues up to the new ``timesteps`` total;
curve rows after the resumed timestep are dropped. If the newest saved model already reached
``timesteps``, nothing is trained. The environment copies restart from fresh episodes, seeded
with ``seed + resumed timesteps`` so a resumed run does not replay the same episodes. The
hyperparameters of the resumed run are the saved model's, and ``config.json`` records them; a
requested hyperparameter that differs from them is refused (``ValueError``) rather than written
and ignored. Every hyperparameter is type- and range-checked when the :class:`TrainingConfig`
is built (:mod:`infoseek.baselines.hyperparameters`), and the run directory is written only
once the model is built.
"""

from __future__ import annotations

import dataclasses
import json
import re
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from infoseek.baselines.callbacks import (
    PeriodicEvaluationCallback,
    PruningCheckpointCallback,
    TqdmProgressCallback,
    truncate_curve,
)
from infoseek.baselines.evaluation import evaluation_seeds
from infoseek.baselines.features import (
    EgocentricObservationExtractor,
    ScaledObservationExtractor,
    egocentric_layout,
    observation_scaling,
)
from infoseek.baselines.hyperparameters import check_hyperparameters
from infoseek.baselines.policy import (
    ALGORITHMS,
    CONFIG_FILE,
    MODEL_FILE,
    check_spaces,
    resolve_model_path,
)
from infoseek.baselines.vec_env import make_training_vec_env
from infoseek.envs import make, registry

__all__ = [
    "CURVE_FILE",
    "DEFAULT_HYPERPARAMETERS",
    "TrainingConfig",
    "TrainingResult",
    "build_model",
    "check_initial_model",
    "find_resume_point",
    "train",
    "write_run_config",
]

CURVE_FILE = "eval.csv"
CHECKPOINT_DIR = "checkpoints"
TENSORBOARD_DIR = "tb"

#: Default SB3 keyword arguments per algorithm (overridden by ``TrainingConfig.hyperparameters``).
#: PPO: ``n_steps`` is per VecEnv slot, so one rollout holds ``n_steps * n_envs * n_agents``
#: transitions (240 * 2 * 4 = 1920 for the default 4-agent run: 4 episodes of 60 steps per slot).
#: ``gamma = 0.95`` (horizon ~20 steps): the summed entropy reduction of a 60-step episode is
#: about the same for every policy that localises eventually, so a discount close to 1 hardly
#: rewards localising early; with 0.995 PPO learned a policy worse than random (README, RL).
DEFAULT_HYPERPARAMETERS: dict[str, dict[str, Any]] = {
    "ppo": {
        "learning_rate": 3e-4,
        "n_steps": 240,
        "batch_size": 240,
        "n_epochs": 10,
        "gamma": 0.95,
        "gae_lambda": 0.95,
        "clip_range": 0.2,
        "ent_coef": 0.0,
        "net_arch": [64, 64],
    },
    "sac": {
        "learning_rate": 3e-4,
        "buffer_size": 200_000,
        "learning_starts": 1_000,
        "batch_size": 256,
        "gamma": 0.95,
        "tau": 0.005,
        "train_freq": 1,
        "gradient_steps": 1,
        "net_arch": [128, 128],
    },
    "td3": {
        "learning_rate": 1e-3,
        "buffer_size": 200_000,
        "learning_starts": 1_000,
        "batch_size": 256,
        "gamma": 0.95,
        "train_freq": 1,
        "gradient_steps": 1,
        "net_arch": [128, 128],
    },
}

_CHECKPOINT_PATTERN = re.compile(r"^model_(\d+)_steps\.zip$")
#: Config keys that must match for a run directory to be resumed.
_RESUME_KEYS = ("algo", "env_id", "n_agents", "action_type", "features")
#: Values of ``TrainingConfig.features``.
FEATURES = ("egocentric", "scaled")


@dataclass(frozen=True)
class TrainingConfig:
    """What to train (everything ``config.json`` records).

    Attributes:
        algo: ``"ppo"``, ``"sac"`` or ``"td3"``.
        env_id: Registered environment id.
        n_agents: Number of agents (one shared policy).
        action_type: ``"continuous"`` or ``"discrete"`` (SAC/TD3: continuous only).
        timesteps: Total agent transitions to train for (> 0).
        seed: Seed of the model, the environment copies and the torch/NumPy streams.
        n_envs: Environment copies (VecEnv slots = ``n_envs * n_agents``).
        num_cpus: Worker processes for the copies (0: in this process).
        env_kwargs: Further environment keywords (``n_particles``, ``max_cycles``, ...);
            ``n_agents`` and ``action_type`` are taken from the fields above.
        hyperparameters: Overrides of :data:`DEFAULT_HYPERPARAMETERS` ``[algo]``; ``net_arch``
            is the hidden layer sizes.
        eval_freq: Timesteps between evaluations (0: only at the end).
        eval_episodes: Seeded episodes per evaluation.
        checkpoint_freq: Timesteps between checkpoints (0: none).
        torch_threads: ``torch.set_num_threads`` during training (None: leave as is).
        features: Observation features inside the network: ``"egocentric"`` (scaled
            observation plus body-frame geometry) or ``"scaled"`` (the scaled observation
            only); see :mod:`infoseek.baselines.features`.
    """

    algo: str = "ppo"
    env_id: str = "bearings_v0"
    n_agents: int = 4
    action_type: str = "continuous"
    timesteps: int = 100_000
    seed: int = 0
    n_envs: int = 2
    num_cpus: int = 0
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    hyperparameters: Mapping[str, Any] = field(default_factory=dict)
    eval_freq: int = 20_000
    eval_episodes: int = 5
    checkpoint_freq: int = 50_000
    torch_threads: int | None = 1
    features: str = "egocentric"
    init_from: str | None = None

    def __post_init__(self) -> None:
        algo = str(self.algo).lower()
        object.__setattr__(self, "algo", algo)
        if algo not in ALGORITHMS:
            raise ValueError(f"algo must be one of {sorted(ALGORITHMS)}, got {self.algo!r}")
        if self.env_id not in registry:
            raise ValueError(f"env_id must be one of {sorted(registry)}, got {self.env_id!r}")
        if self.action_type not in ("continuous", "discrete"):
            raise ValueError(
                f"action_type must be 'continuous' or 'discrete', got {self.action_type!r}"
            )
        if self.features not in FEATURES:
            raise ValueError(f"features must be one of {list(FEATURES)}, got {self.features!r}")
        if self.init_from is not None and algo != "ppo":
            raise ValueError(f"init_from needs algo 'ppo', got {algo!r}")
        if algo != "ppo" and self.action_type != "continuous":
            raise ValueError(f"algo {algo!r} needs action_type='continuous' (PPO handles both)")
        for name, minimum in (
            ("n_agents", 1),
            ("timesteps", 1),
            ("n_envs", 1),
            ("num_cpus", 0),
            ("eval_freq", 0),
            ("eval_episodes", 1),
            ("checkpoint_freq", 0),
        ):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
                raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
        clashes = {"n_agents", "action_type"} & set(self.env_kwargs)
        if clashes:
            raise ValueError(f"env_kwargs must not set {sorted(clashes)}; use the fields")
        unknown = set(self.hyperparameters) - _valid_hyperparameters(algo)
        if unknown:
            raise ValueError(
                f"unknown {algo} hyperparameter(s) {sorted(unknown)}; valid ones are "
                f"{sorted(_valid_hyperparameters(algo))}"
            )
        hyperparameters = check_hyperparameters(ALGORITHMS[algo], self.hyperparameters)
        object.__setattr__(self, "env_kwargs", dict(self.env_kwargs))
        object.__setattr__(self, "hyperparameters", hyperparameters)

    def full_env_kwargs(self) -> dict[str, Any]:
        """Environment keywords including ``n_agents`` and ``action_type``."""
        return {**self.env_kwargs, "n_agents": self.n_agents, "action_type": self.action_type}

    def full_hyperparameters(self) -> dict[str, Any]:
        """Defaults of the algorithm updated with :attr:`hyperparameters`."""
        return {**DEFAULT_HYPERPARAMETERS[self.algo], **self.hyperparameters}

    def to_json(self) -> dict[str, Any]:
        """The ``config.json`` content (plus ``env_kwargs`` including agents/action type)."""
        data = asdict(self)
        data["env_kwargs"] = self.full_env_kwargs()
        data["hyperparameters"] = self.full_hyperparameters()
        return data


def _valid_hyperparameters(algo: str) -> set[str]:
    import inspect

    names = set(inspect.signature(ALGORITHMS[algo].__init__).parameters)
    names -= {
        "self",
        "policy",
        "env",
        "seed",
        "policy_kwargs",
        "tensorboard_log",
        "device",
        "verbose",
        "_init_setup_model",
    }
    return names | {"net_arch"}


@dataclass(frozen=True)
class TrainingResult:
    """Outcome of :func:`train`.

    Attributes:
        model_path: ``out/model.zip``.
        config_path: ``out/config.json``.
        curve_path: ``out/eval.csv``.
        resumed_from: Checkpoint the run continued from (``None``: fresh start).
        start_timesteps: Timesteps already trained at the start.
        timesteps: Timesteps of the saved model.
        wall_seconds: Wall time of this call.
        last_evaluation: Means of the last evaluation (``None`` if none ran).
    """

    model_path: Path
    config_path: Path
    curve_path: Path
    resumed_from: Path | None
    start_timesteps: int
    timesteps: int
    wall_seconds: float
    last_evaluation: dict[str, float] | None


def find_resume_point(out: Path) -> tuple[Path, int] | None:
    """The newest saved model in run directory ``out`` and its timesteps (or ``None``).

    Candidates are ``checkpoints/model_<n>_steps.zip`` (timesteps ``n``) and ``model.zip``
    (timesteps ``trained_timesteps`` of ``config.json``); the largest count wins, ``model.zip``
    on ties.
    """
    candidates: list[tuple[int, int, Path]] = []
    checkpoint_dir = out / CHECKPOINT_DIR
    if checkpoint_dir.is_dir():
        for path in checkpoint_dir.iterdir():
            match = _CHECKPOINT_PATTERN.match(path.name)
            if match:
                candidates.append((int(match.group(1)), 0, path))
    config_path = out / CONFIG_FILE
    if (out / MODEL_FILE).is_file() and config_path.is_file():
        trained = json.loads(config_path.read_text()).get("trained_timesteps")
        if isinstance(trained, int):
            candidates.append((trained, 1, out / MODEL_FILE))
    if not candidates:
        return None
    timesteps, _, path = max(candidates)
    return path, timesteps


def _check_resumable(out: Path, config: TrainingConfig) -> None:
    config_path = out / CONFIG_FILE
    if not config_path.is_file():
        return
    saved = json.loads(config_path.read_text())
    saved.setdefault("features", "scaled")  # runs from before the option had scaled features
    for key in _RESUME_KEYS:
        if saved.get(key) != getattr(config, key):
            raise ValueError(
                f"{out} holds a run with {key}={saved.get(key)!r}, this run has "
                f"{key}={getattr(config, key)!r}; use another --out or the same settings"
            )
    if saved.get("env_kwargs") != json.loads(json.dumps(config.full_env_kwargs())):
        raise ValueError(
            f"{out} holds a run with env_kwargs={saved.get('env_kwargs')}, this run has "
            f"{config.full_env_kwargs()}; use another --out or the same settings"
        )


def _resumed_config(out: Path, config: TrainingConfig) -> TrainingConfig:
    """``config`` with the hyperparameters of the run in ``out`` being resumed.

    A resumed model trains on with the hyperparameters it was saved with, so those are what
    ``config.json`` must record; a ``--hyper`` value that differs from them would be written
    but not used, and is refused.

    Raises:
        ValueError: An explicitly requested hyperparameter differs from the saved run's.
    """
    saved = json.loads((out / CONFIG_FILE).read_text()).get("hyperparameters")
    if not isinstance(saved, dict):  # runs from before config.json recorded them
        return config
    for name, value in config.hyperparameters.items():
        if json.loads(json.dumps(value)) != saved.get(name):
            raise ValueError(
                f"{out} holds a run trained with {name}={saved.get(name)!r}; a resumed run "
                f"keeps the saved model's hyperparameters, so --hyper {name}={value!r} would "
                "not apply: use another --out for new hyperparameters, or drop --hyper"
            )
    return dataclasses.replace(config, hyperparameters=saved)


def write_run_config(
    out: Path,
    config: TrainingConfig,
    trained_timesteps: int | None,
    extra: Mapping[str, Any] | None = None,
) -> Path:
    """Write ``out/config.json`` atomically: ``config.to_json()``, the model's
    ``trained_timesteps`` and file name, and any ``extra`` entries (keys sorted)."""
    data = config.to_json()
    data["trained_timesteps"] = trained_timesteps
    data["model_file"] = MODEL_FILE
    data.update(extra or {})
    path = out / CONFIG_FILE
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    tmp.replace(path)
    return path


def check_initial_model(config: TrainingConfig) -> BaseAlgorithm:
    """Load ``config.init_from`` and check it against the run's environment (before any work).

    Returns:
        The loaded model.

    Raises:
        ValueError: No model there, or a model for another observation layout or action space.
    """
    assert config.init_from is not None
    path = resolve_model_path(config.init_from)
    model = ALGORITHMS[config.algo].load(str(path), device="cpu")
    probe = make(config.env_id, **config.full_env_kwargs())
    try:
        check_spaces(model, probe, where=f"init_from {path}")
    finally:
        probe.close()
    return model


def _with_initial_architecture(config: TrainingConfig, initial: BaseAlgorithm) -> TrainingConfig:
    """``config`` with the hidden layers of the model it starts from.

    Raises:
        ValueError: ``net_arch`` was requested and differs from the initial model's.
    """
    arch = json.loads(json.dumps(initial.policy_kwargs.get("net_arch")))
    requested = config.hyperparameters.get("net_arch")
    if requested is not None and json.loads(json.dumps(requested)) != arch:
        raise ValueError(
            f"init_from {config.init_from} has net_arch={arch}, the run asks for {requested}"
        )
    return dataclasses.replace(config, hyperparameters={**config.hyperparameters, "net_arch": arch})


def build_model(config: TrainingConfig, vec_env: Any, probe_env: Any, out: Path) -> BaseAlgorithm:
    """A fresh SB3 model for ``config`` on ``vec_env`` (features from ``probe_env``; TensorBoard
    logs under ``out``)."""
    hyper = config.full_hyperparameters()
    net_arch = list(hyper.pop("net_arch"))
    offset, scale = observation_scaling(probe_env)
    extractor_kwargs: dict[str, Any] = {"offset": offset, "scale": scale}
    extractor: type[ScaledObservationExtractor] = ScaledObservationExtractor
    if config.features == "egocentric":
        extractor = EgocentricObservationExtractor
        extractor_kwargs["layout"] = egocentric_layout(probe_env)
    policy_kwargs = {
        "net_arch": net_arch,
        "features_extractor_class": extractor,
        "features_extractor_kwargs": extractor_kwargs,
    }
    return ALGORITHMS[config.algo](
        "MlpPolicy",
        vec_env,
        seed=config.seed,
        policy_kwargs=policy_kwargs,
        tensorboard_log=str(out / TENSORBOARD_DIR),
        device="cpu",
        verbose=0,
        **hyper,
    )


def train(
    config: TrainingConfig,
    out: str | Path,
    *,
    progress: bool = True,
    on_evaluation: Callable[[int, dict[str, float]], None] | None = None,
) -> TrainingResult:
    """Train (or resume) the run ``config`` in directory ``out`` (see the module docstring).

    Args:
        config: What to train.
        out: Run directory (created).
        progress: Show a ``tqdm`` progress bar.
        on_evaluation: Called with ``(timesteps, summary)`` after each evaluation.

    Returns:
        Paths and counts of the run.

    Raises:
        ValueError: ``out`` holds an incompatible run.
    """
    start = time.perf_counter()
    out = Path(out)
    config, resume = _resume_point(out, config)
    if config.torch_threads is not None:
        torch.set_num_threads(int(config.torch_threads))
    if resume is not None and resume[1] >= config.timesteps and (out / MODEL_FILE).is_file():
        return _already_trained(out, resume, start)
    config, initial = _initial_model(config, resume)
    previous = json.loads((out / CONFIG_FILE).read_text()) if (out / CONFIG_FILE).is_file() else {}
    vec_env = make_training_vec_env(
        config.env_id, config.full_env_kwargs(), n_envs=config.n_envs, num_cpus=config.num_cpus
    )
    model, start_timesteps = _training_model(config, vec_env, out, resume, initial)
    out.mkdir(parents=True, exist_ok=True)  # the model is built: now the run directory is written
    write_run_config(out, config, previous.get("trained_timesteps"))
    callbacks, evaluation = _training_callbacks(
        config, out, model, vec_env.num_envs, progress, on_evaluation
    )
    model.learn(
        total_timesteps=config.timesteps - start_timesteps,
        callback=callbacks,
        reset_num_timesteps=resume is None,
        tb_log_name=config.algo,
    )
    config_path = _save_trained_model(config, out, model)
    vec_env.close()
    if evaluation.env is not None:
        evaluation.env.close()
    return TrainingResult(
        model_path=out / MODEL_FILE,
        config_path=config_path,
        curve_path=out / CURVE_FILE,
        resumed_from=resume[0] if resume is not None else None,
        start_timesteps=start_timesteps,
        timesteps=int(model.num_timesteps),
        wall_seconds=time.perf_counter() - start,
        last_evaluation=evaluation.last_summary,
    )


def _resume_point(
    out: Path, config: TrainingConfig
) -> tuple[TrainingConfig, tuple[Path, int] | None]:
    """``config`` checked against the run in ``out`` (with that run's hyperparameters when it is
    resumed) and the newest saved model with its timesteps (``None``: a fresh start).

    Raises:
        ValueError: ``out`` holds an incompatible run, or hyperparameters that differ.
    """
    _check_resumable(out, config)
    resume = find_resume_point(out)
    if resume is not None and (out / CONFIG_FILE).is_file():
        config = _resumed_config(out, config)
    return config, resume


def _initial_model(
    config: TrainingConfig, resume: tuple[Path, int] | None
) -> tuple[TrainingConfig, BaseAlgorithm | None]:
    """The model a fresh run starts from (``config.init_from``, else ``None``) and ``config``
    with its hidden layers; a resumed run starts from its own checkpoint (``None``)."""
    if resume is not None or config.init_from is None:
        return config, None
    initial = check_initial_model(config)
    return _with_initial_architecture(config, initial), initial


def _already_trained(out: Path, resume: tuple[Path, int], start: float) -> TrainingResult:
    """The result of a run whose newest saved model (``resume``) already reached the requested
    timesteps: nothing trained, wall time since ``start``."""
    return TrainingResult(
        model_path=out / MODEL_FILE,
        config_path=out / CONFIG_FILE,
        curve_path=out / CURVE_FILE,
        resumed_from=resume[0],
        start_timesteps=resume[1],
        timesteps=resume[1],
        wall_seconds=time.perf_counter() - start,
        last_evaluation=None,
    )


def _training_model(
    config: TrainingConfig,
    vec_env: Any,
    out: Path,
    resume: tuple[Path, int] | None,
    initial: BaseAlgorithm | None,
) -> tuple[BaseAlgorithm, int]:
    """The model to train on ``vec_env`` (new, or loaded from ``resume``) and the timesteps it
    has already trained (0 for a new one)."""
    if resume is None:
        return _fresh_model(config, vec_env, out, initial), 0
    model = _resumed_model(config, vec_env, out, resume[0])
    return model, int(model.num_timesteps)


def _fresh_model(
    config: TrainingConfig, vec_env: Any, out: Path, initial: BaseAlgorithm | None
) -> BaseAlgorithm:
    """A new model for ``config`` on ``vec_env`` (with the policy weights of ``initial`` if
    given); the curve of an earlier run in ``out`` is removed."""
    probe_env = make(config.env_id, **config.full_env_kwargs())
    model = build_model(config, vec_env, probe_env, out)
    probe_env.close()
    if initial is not None:
        model.policy.load_state_dict(initial.policy.state_dict())
    (out / CURVE_FILE).unlink(missing_ok=True)
    return model


def _resumed_model(
    config: TrainingConfig, vec_env: Any, out: Path, resumed_from: Path
) -> BaseAlgorithm:
    """The model saved at ``resumed_from`` on ``vec_env``, reseeded with ``seed + timesteps``
    and with its replay buffer (off-policy) loaded; curve rows after its timesteps dropped."""
    model = ALGORITHMS[config.algo].load(
        str(resumed_from),
        env=vec_env,
        device="cpu",
        tensorboard_log=str(out / TENSORBOARD_DIR),
    )
    start_timesteps = int(model.num_timesteps)
    model.set_random_seed(config.seed + start_timesteps)
    if isinstance(model, OffPolicyAlgorithm):
        buffer = out / CHECKPOINT_DIR / f"model_replay_buffer_{start_timesteps}_steps.pkl"
        if buffer.is_file():
            model.load_replay_buffer(str(buffer))
    truncate_curve(out / CURVE_FILE, start_timesteps)
    return model


def _training_callbacks(
    config: TrainingConfig,
    out: Path,
    model: BaseAlgorithm,
    n_slots: int,
    progress: bool,
    on_evaluation: Callable[[int, dict[str, float]], None] | None,
) -> tuple[list[Any], PeriodicEvaluationCallback]:
    """The callbacks of ``model.learn`` (progress bar, checkpoints every ``checkpoint_freq``
    timesteps over ``n_slots`` VecEnv slots, evaluations) and the evaluation callback."""
    callbacks: list[Any] = [TqdmProgressCallback(config.timesteps, disable=not progress)]
    if config.checkpoint_freq > 0:
        callbacks.append(
            PruningCheckpointCallback(
                save_freq=max(1, config.checkpoint_freq // n_slots),
                save_path=str(out / CHECKPOINT_DIR),
                name_prefix="model",
                save_replay_buffer=isinstance(model, OffPolicyAlgorithm),
            )
        )
    env_kwargs = config.full_env_kwargs()
    evaluation = PeriodicEvaluationCallback(
        make_env=lambda: make(config.env_id, **env_kwargs),
        seeds=evaluation_seeds(config.eval_episodes),
        eval_freq=config.eval_freq if config.eval_freq > 0 else 10 * config.timesteps,
        curve_path=out / CURVE_FILE,
        on_result=on_evaluation,
    )
    callbacks.append(evaluation)
    return callbacks, evaluation


def _save_trained_model(config: TrainingConfig, out: Path, model: BaseAlgorithm) -> Path:
    """Save ``model`` (and its replay buffer, off-policy with checkpoints) and ``config.json``
    with its trained timesteps; returns the ``config.json`` path."""
    model.save(str(out / MODEL_FILE))
    if isinstance(model, OffPolicyAlgorithm) and config.checkpoint_freq > 0:
        model.save_replay_buffer(
            str(out / CHECKPOINT_DIR / f"model_replay_buffer_{model.num_timesteps}_steps.pkl")
        )
    return write_run_config(out, config, int(model.num_timesteps))
