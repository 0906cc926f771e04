"""Environments of the benchmark harness: building them by id or factory, and their defaults.

An environment is named by a registered id (``"bearings_v0"``, :data:`infoseek.envs.registry`)
or by a factory ``"package.module:callable"``. Its settings are the keywords of
:class:`~infoseek.envs.config.SearchConfig`; a registered id's defaults are the config's
keyword defaults overridden by the id's registered ``kwargs``. A run's stored configuration
leaves out every keyword equal to its default (:func:`non_default_env_kwargs`), so the default
spelled out (``--env-kwarg roughening=0.2``, ``--particles 2000``) is the same configuration as
no keyword at all.

Settings are read from the validated config, ``env.unwrapped.config`` (never from attributes
of the environment itself).
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Mapping
from typing import Any

from infoseek.experiments.store import jsonable

__all__ = [
    "changed_settings",
    "check_env_id",
    "default_steps",
    "env_defaults",
    "env_ids",
    "import_object",
    "make_env",
    "non_default_env_kwargs",
]


def import_object(spec: str, what: str) -> Any:
    """The object named ``"package.module:attribute"`` (``attribute`` may be dotted, e.g.
    ``"mypackage.planners:MyPlanner.from_env"``).

    Args:
        spec: The import path.
        what: The option it came from, for error messages (e.g. ``"--planner"``).

    Raises:
        ValueError: Not of that form, the module does not import, or has no such attribute.
    """
    module_name, _, attribute = spec.partition(":")
    if not module_name or not attribute:
        raise ValueError(f"{what} {spec!r}: expected 'package.module:callable'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(f"{what} {spec!r}: cannot import {module_name!r} ({error})") from None
    target: Any = module
    try:
        for name in attribute.split("."):
            target = getattr(target, name)
    except AttributeError:
        raise ValueError(f"{what} {spec!r}: {module_name!r} has no {attribute!r}") from None
    return target


def env_ids() -> list[str]:
    """The registered environment ids."""
    from infoseek.envs import registry

    return sorted(registry)


def check_env_id(env: str) -> None:
    """Raise ``ValueError`` unless ``env`` is a registered id or ``"module:callable"``."""
    if ":" in env:
        if not callable(import_object(env, "--env")):
            raise ValueError(f"--env {env!r} is not callable")
        return
    valid = env_ids()
    if env not in valid:
        raise ValueError(f"unknown environment {env!r}; expected one of {valid}")


def _accepts(factory: Any, keyword: str) -> bool:
    """Whether ``factory`` takes the keyword ``keyword`` (by name or through ``**kwargs``)."""
    try:
        parameters = inspect.signature(factory).parameters.values()
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False
    return any(p.name == keyword or p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters)


def make_env(env: str, **kwargs: Any) -> Any:
    """Build environment ``env``: a registered id, or a ``"module:callable"`` factory.

    The environment is built with ``belief_in_infos=True`` (every agent's belief view in its
    infos, what the planners read; a factory that does not take the keyword is built without
    it). That setting is not part of the stored configuration, as it changes no decision.
    """
    if ":" in env:
        factory = import_object(env, "--env")
        if _accepts(factory, "belief_in_infos"):
            kwargs = {**kwargs, "belief_in_infos": True}
        return factory(**kwargs)
    from infoseek.envs import make

    return make(env, **{**kwargs, "belief_in_infos": True})


def env_defaults(env: str) -> dict[str, Any]:
    """Every configuration keyword of the registered environment ``env`` with its default:
    the keyword defaults of :class:`~infoseek.envs.config.SearchConfig`, overridden by the
    id's registered ``kwargs``."""
    from infoseek.envs import registry
    from infoseek.envs.config import SearchConfig

    parameters = inspect.signature(SearchConfig.__init__).parameters.values()
    defaults = {
        p.name: p.default
        for p in parameters
        if p.kind is inspect.Parameter.KEYWORD_ONLY and p.default is not inspect.Parameter.empty
    }
    defaults.update(registry[env].kwargs)
    return defaults


def non_default_env_kwargs(env: str, env_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` without the keywords whose value is the registered environment's default
    (:func:`env_defaults`; values compared in their JSON form, so ``(5, 5)`` equals
    ``[5.0, 5.0]``); all of them are kept for a ``"module:callable"`` environment."""
    if ":" in env:
        return dict(env_kwargs)
    defaults = env_defaults(env)
    missing = object()
    return {
        key: value
        for key, value in env_kwargs.items()
        if defaults.get(key, missing) is missing or jsonable(defaults[key]) != jsonable(value)
    }


def default_steps(env: str, env_kwargs: Mapping[str, Any]) -> int:
    """The environment's own episode length (``max_cycles``) for these keyword arguments."""
    instance = make_env(env, n_agents=1, **env_kwargs)
    try:
        return int(instance.unwrapped.config.max_cycles)
    finally:
        instance.close()


def changed_settings(env: str, base: str) -> dict[str, Any]:
    """The registered keyword arguments of ``env`` that differ from ``base``'s (less the
    environment's name), sorted by name: the settings that make ``base`` into ``env`` when the
    two share their code (``beacon_v1`` from ``beacon_v0``)."""
    from infoseek.envs.registration import registry

    for name in (env, base):
        if name not in registry:
            raise ValueError(f"unknown environment {name!r}; expected one of {env_ids()}")
    mine, theirs = registry[env].kwargs, registry[base].kwargs
    return {
        key: value
        for key, value in sorted(mine.items())
        if key != "name" and theirs.get(key) != value
    }
