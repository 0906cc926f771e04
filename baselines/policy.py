"""Trained policies behind the planners' interface: ``act(observations, infos) -> actions``.

A training run (:mod:`infoseek.baselines.training`) writes ``DIR/model.zip`` (Stable-Baselines3
archive) and ``DIR/config.json`` (environment id and keywords, algorithm, action type, number
of agents, seed, timesteps). :func:`load_policy` turns either file (or ``DIR``) into a
:class:`TrainedPolicy`::

    env = infoseek.envs.make("bearings_v0")
    policy = load_policy("runs/ppo/model.zip", env)      # checks the spaces against env
    observations, infos = env.reset(seed=0)
    while env.agents:
        observations, *_, infos = env.step(policy.act(observations, infos))

All agents share the one network (parameter sharing): ``act`` stacks the observations of the
agents present into a ``(n, obs_dim)`` batch and runs one forward pass. Actions are
deterministic by default (the mean of the Gaussian / the arg-max of the categorical).

**Benchmark hook.** ``infoseek bench --policy DIR/model.zip`` calls
``load_policy(path, env, seed=policy_seed)`` for each trial; ``seed`` only matters for
``deterministic=False`` (sampling uses a private torch generator state, never the global one).
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import torch
from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.distributions import (
    CategoricalDistribution,
    DiagGaussianDistribution,
)
from stable_baselines3.common.policies import ActorCriticPolicy

__all__ = [
    "ALGORITHMS",
    "CONFIG_FILE",
    "MODEL_FILE",
    "TrainedPolicy",
    "check_spaces",
    "load_policy",
    "read_run_config",
    "resolve_model_path",
    "shipped_model",
]

#: Algorithm name -> Stable-Baselines3 class.
ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC, "td3": TD3}
MODEL_FILE = "model.zip"
CONFIG_FILE = "config.json"
#: Trained models installed with the package: ``SHIPPED_MODELS_DIR/<name>/`` holds
#: ``model.zip``, ``config.json`` (how it was trained) and ``eval.csv`` (its training curve).
SHIPPED_MODELS_DIR = Path(__file__).resolve().parent / "models"
DEFAULT_SHIPPED_MODEL = "dagger_bearings_v0_4agents"


def shipped_model(name: str = DEFAULT_SHIPPED_MODEL) -> Path:
    """Path of the ``model.zip`` of a model shipped with infoseek.

    ``load_policy(shipped_model(), env)`` gives the policy trained to imitate
    ``PairwiseNodePlanner`` on ``bearings_v0`` with 4 agents and ``belief_moments=True`` (build
    ``env`` with that keyword); ``"dagger_beacon_v0_4agents"`` imitates ``SingleNodePlanner``
    on ``beacon_v0``; ``"ppo_bearings_v0_4agents"`` is the earlier PPO policy. How they were
    trained and how they compare: ``docs/results/learned.md`` and ``docs/results/rl.md``.

    Args:
        name: Directory name under :data:`SHIPPED_MODELS_DIR`.

    Raises:
        ValueError: No shipped model of that name (the message lists the available ones).
    """
    path = SHIPPED_MODELS_DIR / name / MODEL_FILE
    if not path.is_file():
        available = sorted(
            p.name for p in SHIPPED_MODELS_DIR.glob("*") if (p / MODEL_FILE).is_file()
        )
        raise ValueError(f"no shipped model {name!r}; available: {available}")
    return path


def resolve_model_path(path: str | Path) -> Path:
    """``DIR``, ``DIR/model.zip`` or ``DIR/config.json`` -> the model archive path.

    Raises:
        ValueError: nothing usable at ``path``.
    """
    path = Path(path)
    if path.is_dir():
        path = path / MODEL_FILE
    elif path.name == CONFIG_FILE:
        path = path.with_name(MODEL_FILE)
    if not path.is_file():
        raise ValueError(f"path {str(path)!r}: no trained model (expected DIR or DIR/{MODEL_FILE})")
    return path


def read_run_config(model_path: str | Path) -> dict[str, Any] | None:
    """The ``config.json`` next to ``model_path`` (``None`` if there is none)."""
    config_path = Path(model_path).with_name(CONFIG_FILE)
    if not config_path.is_file():
        return None
    with config_path.open() as handle:
        return json.load(handle)


def _bounds_within(space: Any, model_space: Any) -> bool:
    """Whether the Box ``space`` lies inside ``model_space`` wherever both bounds are finite.

    The environment's position bounds grow with its episode length (``max_cycles``), so a
    policy trained on 60-step episodes may act in 20-step ones, whose observations lie inside
    the trained range; models saved before the bounds became finite stored +-inf.
    """
    low = np.asarray(getattr(space, "low", 0.0), dtype=np.float64)
    high = np.asarray(getattr(space, "high", 0.0), dtype=np.float64)
    model_low = np.asarray(getattr(model_space, "low", 0.0), dtype=np.float64)
    model_high = np.asarray(getattr(model_space, "high", 0.0), dtype=np.float64)
    lows = np.isfinite(low) & np.isfinite(model_low)
    highs = np.isfinite(high) & np.isfinite(model_high)
    return bool(np.all(low[lows] >= model_low[lows]) and np.all(high[highs] <= model_high[highs]))


def check_spaces(model: BaseAlgorithm, env: Any, where: str = "load_policy") -> None:
    """Raise ``ValueError`` unless every agent's spaces in ``env`` fit the model's: the same
    observation shape with bounds inside the model's (:func:`_bounds_within`), the same action
    space.

    Args:
        model: The loaded SB3 model.
        env: Parallel environment (``possible_agents``, ``observation_space``, ``action_space``).
        where: Prefix of the error message.
    """
    for agent in env.possible_agents:
        observation_space = env.observation_space(agent)
        action_space = env.action_space(agent)
        if observation_space.shape != model.observation_space.shape or not _bounds_within(
            observation_space, model.observation_space
        ):
            raise ValueError(
                f"{where}: observation space of {agent} {observation_space} does not fit in the "
                f"model's {model.observation_space} (trained for another environment, number of "
                "agents, or shorter episodes?)"
            )
        if action_space != model.action_space:
            raise ValueError(
                f"{where}: action space of {agent} {action_space} does not match the model's "
                f"{model.action_space} (continuous vs discrete actions, or other bounds?)"
            )


class TrainedPolicy:
    """A Stable-Baselines3 model acting for every agent of a parallel env (shared parameters).

    Args:
        model: The SB3 model (PPO, SAC or TD3).
        deterministic: Use the mean / arg-max action (default) rather than sampling.
        seed: Seed of the private torch generator used when ``deterministic=False``.
        config: The run's ``config.json`` content, if known (``env_id``, ``env_kwargs``, ...).
    """

    def __init__(
        self,
        model: BaseAlgorithm,
        *,
        deterministic: bool = True,
        seed: int | None = None,
        config: Mapping[str, Any] | None = None,
    ) -> None:
        self.model = model
        self.deterministic = bool(deterministic)
        self.config = dict(config) if config is not None else None
        self.discrete = not isinstance(model.action_space, gymnasium.spaces.Box)
        self._torch_state: torch.Tensor | None = None
        self.reset(seed)

    def reset(self, seed: int | None = None) -> None:
        """Reseed the sampling generator (only used when ``deterministic=False``)."""
        generator = torch.Generator()
        if seed is None:
            generator.seed()
        else:
            generator.manual_seed(int(seed))
        self._torch_state = generator.get_state()

    def act(self, observations: Mapping[str, Any], infos: Mapping[str, Any]) -> dict[str, Any]:
        """``{agent: action}`` for every agent in ``observations`` (``infos`` is not used).

        Continuous actions are ``(action_dim,)`` float32 arrays inside the Box; discrete ones
        are Python ints.

        Raises:
            ValueError: an observation of the wrong shape.
        """
        agents = list(observations)
        if not agents:
            return {}
        expected = self.model.observation_space.shape
        batch = []
        for agent in agents:
            observation = np.asarray(observations[agent], dtype=np.float32)
            if observation.shape != expected:
                raise ValueError(
                    f"observation of {agent} has shape {observation.shape}, the model expects "
                    f"{expected}"
                )
            batch.append(observation)
        stacked = np.stack(batch)
        if self.deterministic:
            actions = self._deterministic_actions(stacked)
        else:
            with torch.random.fork_rng(devices=[]):
                assert self._torch_state is not None  # seeded in __init__
                torch.set_rng_state(self._torch_state)
                actions, _ = self.model.predict(stacked, deterministic=False)
                self._torch_state = torch.get_rng_state()
        if self.discrete:
            return {agent: int(actions[k]) for k, agent in enumerate(agents)}
        return {agent: np.asarray(actions[k], dtype=np.float32) for k, agent in enumerate(agents)}

    def _deterministic_actions(self, stacked: np.ndarray) -> np.ndarray:
        """``model.predict(stacked, deterministic=True)`` without its per-call checks, for an
        actor-critic policy with a diagonal Gaussian or categorical action distribution: the
        same numbers (the mean clipped to the Box as SB3 does, or the arg-max); other models go
        through ``predict``."""
        policy = self.model.policy
        distribution = getattr(policy, "action_dist", None)
        fast = isinstance(policy, ActorCriticPolicy) and not policy.squash_output
        if not fast or not isinstance(
            distribution, DiagGaussianDistribution | CategoricalDistribution
        ):
            actions, _ = self.model.predict(stacked, deterministic=True)
            return np.asarray(actions)
        actor: Any = policy  # an ActorCriticPolicy (checked above)
        with torch.inference_mode():
            features = actor.extract_features(
                torch.from_numpy(stacked), actor.pi_features_extractor
            )
            output = actor.action_net(actor.mlp_extractor.forward_actor(features))
        if isinstance(distribution, CategoricalDistribution):
            return torch.argmax(output, dim=1).numpy()
        space = self.model.action_space
        assert isinstance(space, gymnasium.spaces.Box)
        return np.clip(output.numpy().reshape((-1, *space.shape)), space.low, space.high)


def load_policy(
    path: str | Path,
    env: Any = None,
    *,
    seed: int | None = None,
    deterministic: bool = True,
) -> TrainedPolicy:
    """Load a trained policy; with ``env``, check that it fits that environment.

    This is also the hook of ``infoseek bench --policy PATH`` (called as
    ``load_policy(path, env, seed=policy_seed)``).

    Args:
        path: ``DIR``, ``DIR/model.zip`` or ``DIR/config.json`` of a training run (a checkpoint
            ``.zip`` also works; its algorithm is then taken from ``config.json`` next to it or
            from the parent run directory, else tried in turn).
        env: Parallel environment the policy will act in; its observation and action spaces
            must equal the model's (for every agent). ``None`` skips the check.
        seed: Seed of the sampling generator (only for ``deterministic=False``).
        deterministic: Deterministic actions (default).

    Returns:
        A :class:`TrainedPolicy` (``policy.config`` holds ``config.json`` if found).

    Raises:
        ValueError: no model at ``path``, unknown algorithm, or spaces that do not match ``env``.
    """
    model_path = resolve_model_path(path)
    config = read_run_config(model_path)
    if config is None and model_path.parent.name == "checkpoints":
        config = read_run_config(model_path.parent.parent / MODEL_FILE)
    if config is not None:
        algo = str(config.get("algo", "")).lower()
        if algo not in ALGORITHMS:
            raise ValueError(f"{model_path}: config.json names unknown algorithm {algo!r}")
        model = ALGORITHMS[algo].load(str(model_path), device="cpu")
    else:
        model = _load_any(model_path)
    if env is not None:
        check_spaces(model, env)
        if config is not None:
            env_name = env.unwrapped.metadata.get("name")
            if config.get("env_id") not in (None, env_name):
                warnings.warn(
                    f"{model_path} was trained on {config.get('env_id')!r}, acting in "
                    f"{env_name!r} (the spaces match)",
                    stacklevel=2,
                )
    return TrainedPolicy(model, deterministic=deterministic, seed=seed, config=config)


def _load_any(model_path: Path) -> BaseAlgorithm:
    errors = []
    for name, cls in ALGORITHMS.items():
        try:
            return cls.load(str(model_path), device="cpu")
        except Exception as error:  # try the next algorithm
            errors.append(f"{name}: {error}")
    raise ValueError(f"{model_path}: not a PPO/SAC/TD3 model ({'; '.join(errors)})")
