"""infoseek environments: sensors, vehicles, target models, particle beliefs and PettingZoo envs.

``make(env_id, **kwargs)`` builds a registered environment and ``registry`` lists them
(``"bearings_v0"``, ``"beacon_v0"``, ``"beacon_v1"``); ``B`` batched copies stepped at once are a
:class:`~infoseek.envs.core.SearchCore`, which :func:`infoseek.baselines.make_vec` wraps as a
Stable-Baselines3 ``VecEnv``. The versioned modules ``infoseek.envs.bearings_v0``,
``infoseek.envs.beacon_v0`` and ``infoseek.envs.beacon_v1`` expose ``parallel_env``, ``env``
(AEC) and ``raw_env``; their module docstrings are the manuals. Everything else is imported
lazily on first attribute access, so ``import infoseek.envs.sensors`` does not import
PettingZoo.

Importing the package registers the single-agent forms with Gymnasium
(``gymnasium.make("infoseek/Bearings-v0")``, :mod:`infoseek.envs.single_agent`) and changes
no process-wide setting (the C heap tuning of :mod:`infoseek.envs.heap` is opt-in).
"""

from __future__ import annotations

import importlib
from typing import Any

from infoseek.envs.registration import EnvSpec, make, register, registry
from infoseek.envs.single_agent import register_with_gymnasium as _register_with_gymnasium

_register_with_gymnasium()

__all__ = [
    "EnvSpec",
    "InformationSeekingEnv",
    "beacon_v0",
    "beacon_v1",
    "bearings_v0",
    "make",
    "register",
    "registry",
]

_LAZY_ATTRIBUTES = {
    "InformationSeekingEnv": "infoseek.envs.search_env",
}
_LAZY_MODULES = ("bearings_v0", "beacon_v0", "beacon_v1")


def __getattr__(name: str) -> Any:
    if name in _LAZY_ATTRIBUTES:
        return getattr(importlib.import_module(_LAZY_ATTRIBUTES[name]), name)
    if name in _LAZY_MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
