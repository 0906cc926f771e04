"""Reinforcement-learning baselines: one policy shared by all agents, trained with SB3.

Needs the optional ``rl`` dependencies (``pip install infoseek[rl]``: stable-baselines3,
supersuit, torch, tensorboard); they are imported on first attribute access, so
``import infoseek.baselines`` itself is cheap.

* :func:`load_policy` (``path, env=None, *, seed=None, deterministic=True``) -> a
  :class:`TrainedPolicy` with the planners' ``act(observations, infos)``; also the hook of
  ``infoseek bench --policy DIR/model.zip``.
* :func:`shipped_model` -> path of a model trained by us and installed with the package
  (``load_policy(shipped_model(), env)``: the imitation of the pairwise-node planner on
  ``bearings_v0`` with 4 agents and ``belief_moments=True``).
* :func:`train` with a :class:`TrainingConfig` -> run directory with ``model.zip``,
  ``config.json``, the ``eval.csv`` training curve, checkpoints and TensorBoard logs
  (:mod:`infoseek.baselines.training`).
* :func:`evaluate_policy` -> seeded-episode metrics (:mod:`infoseek.baselines.evaluation`).
* :func:`make_vec` (``env_id, num_envs=B, n_workers=1, **kwargs``) -> a Stable-Baselines3
  ``VecEnv`` of ``B`` batched copies of an environment, one slot per agent
  (:mod:`infoseek.baselines.vector`); :func:`make_training_vec_env` is the one training uses
  (:mod:`infoseek.baselines.vec_env`).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "ALGORITHMS",
    "DEFAULT_HYPERPARAMETERS",
    "EvaluationResult",
    "SearchVecEnv",
    "TrainedPolicy",
    "TrainingConfig",
    "TrainingResult",
    "evaluate_policy",
    "load_policy",
    "make_training_vec_env",
    "make_vec",
    "shipped_model",
    "train",
]

_LAZY_ATTRIBUTES = {
    "ALGORITHMS": "infoseek.baselines.policy",
    "TrainedPolicy": "infoseek.baselines.policy",
    "load_policy": "infoseek.baselines.policy",
    "shipped_model": "infoseek.baselines.policy",
    "DEFAULT_HYPERPARAMETERS": "infoseek.baselines.training",
    "TrainingConfig": "infoseek.baselines.training",
    "TrainingResult": "infoseek.baselines.training",
    "train": "infoseek.baselines.training",
    "EvaluationResult": "infoseek.baselines.evaluation",
    "evaluate_policy": "infoseek.baselines.evaluation",
    "make_training_vec_env": "infoseek.baselines.vec_env",
    "SearchVecEnv": "infoseek.baselines.vector",
    "make_vec": "infoseek.baselines.vector",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY_ATTRIBUTES:
        try:
            module = importlib.import_module(_LAZY_ATTRIBUTES[name])
        except ImportError as error:
            raise ImportError(
                f"infoseek.baselines.{name} needs the optional RL dependencies "
                f"(pip install 'infoseek[rl]'): {error}"
            ) from error
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
