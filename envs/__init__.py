"""infoseek environments: sensors, vehicles, target models, particle beliefs and PettingZoo envs.

``make(env_id, **kwargs)`` builds a registered environment, ``make_vec(env_id, num_envs=B)``
a Stable-Baselines3 ``VecEnv`` of ``B`` batched copies (:mod:`infoseek.envs.vector`), and
``registry`` lists them
(``"bearings_v0"``, ``"beacon_v0"``). The versioned modules ``infoseek.envs.bearings_v0`` and
``infoseek.envs.beacon_v0`` expose ``parallel_env``, ``env`` (AEC) and ``raw_env``; their module
docstrings are the manuals. Everything else is imported lazily on first attribute access, so
``import infoseek.envs.sensors`` does not import PettingZoo.

Importing the package registers the single-agent forms with Gymnasium
(``gymnasium.make("infoseek/Bearings-v0")``, :mod:`infoseek.envs.single_agent`) and tunes the C
heap so that NumPy temporaries reuse freed pages (:mod:`infoseek.envs.heap`; opt out with
``INFOSEEK_HEAP_TUNING=0``).
"""

from __future__ import annotations

import importlib
from typing import Any

from infoseek.envs import heap as _heap  # noqa: F401  (tunes the heap once, on import)
from infoseek.envs.registration import EnvSpec, make, register, registry
from infoseek.envs.single_agent import register_with_gymnasium as _register_with_gymnasium

_register_with_gymnasium()

__all__ = [
    "EnvSpec",
    "InformationSeekingEnv",
    "beacon_v0",
    "bearings_v0",
    "make",
    "make_vec",
    "register",
    "registry",
]

_LAZY_ATTRIBUTES = {
    "InformationSeekingEnv": "infoseek.envs.search_env",
    "make_vec": "infoseek.envs.vector",
}
_LAZY_MODULES = ("bearings_v0", "beacon_v0")


def __getattr__(name: str) -> Any:
    if name in _LAZY_ATTRIBUTES:
        return getattr(importlib.import_module(_LAZY_ATTRIBUTES[name]), name)
    if name in _LAZY_MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
