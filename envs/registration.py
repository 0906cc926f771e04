"""Registry of the versioned information-seeking environments.

``infoseek.envs.registry`` maps an environment id to an :class:`EnvSpec`; ``make`` builds one::

    import infoseek.envs
    env = infoseek.envs.make("bearings_v0", n_agents=2)              # parallel API (default)
    aec = infoseek.envs.make("beacon_v0", parallel=False, n_agents=3)  # AEC API

Entry points are import strings (``"module:function"``) resolved only when an environment is
made, so importing the registry does not import the environment stack.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

__all__ = ["EnvSpec", "make", "register", "registry"]


def _frozen_mapping(value: Mapping[str, Any] | None = None) -> Mapping[str, Any]:
    return MappingProxyType(dict(value or {}))


@dataclass(frozen=True)
class EnvSpec:
    """How to build one registered environment.

    Attributes:
        id: Environment id, e.g. ``"bearings_v0"`` (name plus version suffix).
        entry_point: Import string ``"module:function"`` of the parallel-API constructor, e.g.
            ``"infoseek.envs.bearings_v0:parallel_env"``.
        aec_entry_point: Import string of the AEC-API constructor (``make(..., parallel=False)``),
            e.g. ``"infoseek.envs.bearings_v0:env"``.
        kwargs: Default keyword arguments passed to the constructor before the caller's (the
            caller's win). For the built-in ids these are the version's defaults, which the
            versioned module re-exports as ``DEFAULT_CONFIG`` and documents in its manual.
        description: One line shown in listings.
    """

    id: str
    entry_point: str
    aec_entry_point: str
    kwargs: Mapping[str, Any] = field(default_factory=_frozen_mapping)
    description: str = ""

    def __post_init__(self) -> None:
        for name in ("entry_point", "aec_entry_point"):
            value = getattr(self, name)
            if not isinstance(value, str) or value.count(":") != 1:
                raise ValueError(f"EnvSpec.{name} must be 'module:function', got {value!r}")
        object.__setattr__(self, "kwargs", _frozen_mapping(self.kwargs))

    def load(self, parallel: bool = True) -> Callable[..., Any]:
        """Import and return the constructor of the parallel (default) or AEC version."""
        module_name, function_name = (self.entry_point if parallel else self.aec_entry_point).split(
            ":"
        )
        return getattr(importlib.import_module(module_name), function_name)


registry: dict[str, EnvSpec] = {}
"""Environment id -> :class:`EnvSpec` of every registered environment."""


def register(spec: EnvSpec) -> None:
    """Add ``spec`` to :data:`registry`.

    Raises:
        TypeError: ``spec`` is not an :class:`EnvSpec`.
        ValueError: its id is already registered.
    """
    if not isinstance(spec, EnvSpec):
        raise TypeError(f"spec must be an EnvSpec, got {type(spec).__name__}")
    if spec.id in registry:
        raise ValueError(f"environment id {spec.id!r} is already registered")
    registry[spec.id] = spec


def make(env_id: str, *, parallel: bool = True, **kwargs: Any) -> Any:
    """Build a registered environment.

    Args:
        env_id: A key of :data:`registry` (``"bearings_v0"``, ``"beacon_v0"``, ...).
        parallel: ``True`` (default) returns the PettingZoo ``ParallelEnv``; ``False`` returns
            the AEC version (``<module>.env``, wrapped with the order-enforcing wrapper).
        **kwargs: Configuration keywords of the environment (see its module manual); they
            override ``spec.kwargs``. Unknown keywords raise ``ValueError``.

    Raises:
        ValueError: ``env_id`` is not registered (the message lists the valid ids).
    """
    if env_id not in registry:
        raise ValueError(f"unknown environment id {env_id!r}; valid ids are {sorted(registry)}")
    spec = registry[env_id]
    return spec.load(parallel)(**{**spec.kwargs, **kwargs})


register(
    EnvSpec(
        id="bearings_v0",
        entry_point="infoseek.envs.bearings_v0:parallel_env",
        aec_entry_point="infoseek.envs.bearings_v0:env",
        kwargs={
            "name": "bearings_v0",
            "sensor": "bearing",
            "sensor_kwargs": MappingProxyType({"sigma": 0.1}),
            "vehicle": "airplane",
            "vehicle_kwargs": MappingProxyType({"speed": 1.0, "max_turn_rate": 0.5}),
            "target_space": "planar",
            "target_motion": "stationary",
            "n_agents": 4,
            "n_particles": 2000,
            "max_cycles": 60,
            "dt": 1.0,
            "min_separation": 1.0,
            "start_center": (5.0, 5.0),
        },
        description="airplanes with bearings-only sensors, target (x, y) (paper section IV-A)",
    )
)
register(
    EnvSpec(
        id="beacon_v0",
        entry_point="infoseek.envs.beacon_v0:parallel_env",
        aec_entry_point="infoseek.envs.beacon_v0:env",
        kwargs={
            "name": "beacon_v0",
            "sensor": "beacon",
            "sensor_kwargs": MappingProxyType({"moment": 1000.0, "noise_std": 1.0}),
            "vehicle": "quadrotor",
            "vehicle_kwargs": MappingProxyType({"max_accel": 1.0, "max_speed": 2.0}),
            "target_space": "planar_with_orientation",
            "target_motion": "stationary",
            "n_agents": 4,
            "n_particles": 2000,
            "max_cycles": 40,
            "dt": 1.0,
            "min_separation": 1.0,
            "start_center": (5.0, 5.0),
            "filter_max_snr": 5.0,
            "tempering_ess": 0.0,
        },
        description="quadrotors with rescue-beacon receivers, target (x, y, psi) (section IV-B)",
    )
)
register(
    EnvSpec(
        id="beacon_v1",
        entry_point="infoseek.envs.beacon_v1:parallel_env",
        aec_entry_point="infoseek.envs.beacon_v1:env",
        kwargs={
            **registry["beacon_v0"].kwargs,
            "name": "beacon_v1",
            "resample_threshold": 0.5,
            "tempering_ess": 0.5,
        },
        description="beacon_v0 with the beliefs resampling at half the particles and "
        "progressive correction at half the effective sample size",
    )
)
