"""Policies by planner label, for the command line and the benchmark harness.

A benchmark group's *planner label* names the policy that drives its vehicles:

* a scripted planner's name (:data:`PLANNER_NAMES`, built by :func:`make_policy`);
* a factory ``"package.module:callable"``, called as ``factory(env, seed=..., **options)``
  (e.g. the clairvoyant reference, :mod:`infoseek.experiments.clairvoyant`);
* a trained RL policy's ``"policy:..."`` label (:mod:`infoseek.experiments.policy_labels`),
  loaded by ``infoseek.baselines.load_policy``.

The label is part of every trial's key and policy seed, so it is stored and must keep naming
the same policy: a factory's import path is part of the results that name it.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import infoseek.planners as planners
from infoseek.experiments.environments import import_object
from infoseek.experiments.policy_labels import (
    POLICY_PREFIX,
    is_policy,
    policy_file,
    portable_label,
)
from infoseek.planners.registry import PLANNER_CLASSES

__all__ = [
    "PLANNER_CLASSES",
    "PLANNER_NAMES",
    "build_policy",
    "check_planner",
    "check_policy_path",
    "make_policy",
    "trained_policy_loader",
]

PLANNER_NAMES: list[str] = list(PLANNER_CLASSES)


def make_policy(name: str, env: Any, seed: int | None = None, **options: Any) -> Any:
    """Build the scripted policy called ``name`` for ``env``.

    Args:
        name: One of :data:`PLANNER_NAMES`.
        env: The environment the policy will act in (parallel API).
        seed: Seed of the policy's own random stream (planning-particle subsampling, random
            actions).
        **options: Planner options, passed to ``from_env``.

    Returns:
        An object with ``act(observations, infos) -> actions``.
    """
    if name not in PLANNER_CLASSES:
        raise ValueError(f"unknown planner {name!r}; expected one of {PLANNER_NAMES}")
    cls = getattr(planners, PLANNER_CLASSES[name])
    return cls.from_env(env, seed=seed, **options)


def check_planner(planner: str) -> None:
    """Raise ``ValueError`` unless ``planner`` is a scripted planner name, a factory path or a
    policy label."""
    if is_policy(planner):
        return
    if ":" in planner:
        if not callable(import_object(planner, "--planner")):
            raise ValueError(f"--planner {planner!r} is not callable")
        return
    if planner not in PLANNER_NAMES:
        raise ValueError(f"unknown planner {planner!r}; expected one of {PLANNER_NAMES}")


def trained_policy_loader() -> Callable[..., Any]:
    """The loader of trained RL policies, ``infoseek.baselines.load_policy(path, env, seed=...)``.

    Raises:
        ValueError: :mod:`infoseek.baselines` does not provide ``load_policy``.
    """
    try:
        import infoseek.baselines as baselines
    except ImportError as error:  # pragma: no cover - package always present
        raise ValueError(f"--policy needs infoseek.baselines ({error})") from None
    loader = getattr(baselines, "load_policy", None)
    if not callable(loader):
        raise ValueError(
            "--policy: loading trained RL policies needs infoseek.baselines.load_policy"
            "(path, env, seed=...), which this installation does not provide yet; "
            "use --planner with one of " + str(PLANNER_NAMES)
        )
    return loader


def check_policy_path(path: str, store: str | os.PathLike[str] | None = None) -> str:
    """Validate a ``--policy`` path; returns its planner label.

    Args:
        path: The model file (or run directory).
        store: The results directory the label is for: the label is then portable
            (:func:`infoseek.experiments.policy_labels.portable_label`, what ``infoseek bench``
            uses); ``None`` gives ``"policy:<absolute path>"``, valid for any store on this
            machine but not portable.
    """
    resolved = Path(path).expanduser().resolve()
    if not resolved.exists():
        raise ValueError(f"--policy {path!r}: no such file or directory")
    for module in ("torch", "stable_baselines3"):
        try:
            importlib.import_module(module)
        except ImportError:
            raise ValueError(
                f"--policy needs the RL dependencies ({module} is not installed): "
                "pip install 'infoseek[rl]'"
            ) from None
    trained_policy_loader()
    return POLICY_PREFIX + str(resolved) if store is None else portable_label(resolved, store)


def build_policy(
    planner: str,
    env: Any,
    seed: int,
    options: Mapping[str, Any],
    model_file: str | None = None,
) -> Any:
    """The policy called ``planner`` (module docstring).

    Args:
        planner: The planner label.
        env: The environment it acts in.
        seed: Its seed.
        options: Planner options (scripted planners and factories).
        model_file: The model file of a policy label (resolved against its store); ``None``:
            the label's own path (absolute labels).
    """
    if is_policy(planner):
        path = model_file if model_file is not None else str(policy_file(planner, "."))
        return trained_policy_loader()(path, env, seed=seed)
    if ":" in planner:
        return import_object(planner, "--planner")(env, seed=seed, **options)
    return make_policy(planner, env, seed=seed, **options)
