"""Sensor models (eq. 3): bearings-only, range, and the avalanche-rescue beacon.

Every model implements :class:`~infoseek.envs.sensors.base.Sensor`; the bearing and range
sensors also implement :class:`~infoseek.envs.sensors.base.AdditiveNoiseSensor`. All three also
offer ``bin_probabilities(edges, poses, particles) -> (..., N, Q)``, the exact probability of
each observation bin, for mutual-information quadrature with likelihoods narrower than any grid.

Use :func:`make_sensor` to build one from a registry name (see :data:`SENSOR_REGISTRY`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from infoseek.envs.registries import Registry
from infoseek.envs.sensors.base import (
    AdditiveNoiseSensor,
    ObservationDomain,
    Sensor,
    ShiftKernelSensor,
)
from infoseek.envs.sensors.beacon import BeaconSensor
from infoseek.envs.sensors.bearing import BearingSensor
from infoseek.envs.sensors.range import RangeSensor

__all__ = [
    "SENSOR_REGISTRY",
    "AdditiveNoiseSensor",
    "BeaconSensor",
    "BearingSensor",
    "ObservationDomain",
    "RangeSensor",
    "Sensor",
    "ShiftKernelSensor",
    "make_sensor",
]

#: Registry name -> sensor class (``SENSOR_REGISTRY.register(name, cls)`` adds one).
SENSOR_REGISTRY: Registry[Callable[..., Sensor]] = Registry("sensor", Sensor)
for _cls in (BearingSensor, BeaconSensor, RangeSensor):
    SENSOR_REGISTRY.register(_cls.name, _cls)


def make_sensor(spec: str | Sensor, **kwargs: Any) -> Sensor:
    """Build a sensor from a registry name, or pass an instance through.

    Args:
        spec: A name in :data:`SENSOR_REGISTRY` (``"bearing"``, ``"beacon"``, ``"range"``) or a
            sensor instance.
        **kwargs: Constructor arguments for a named sensor; must be empty for an instance.

    Returns:
        The sensor.

    Raises:
        ValueError: If ``spec`` is an unknown name (the message lists the valid names).
        TypeError: If ``kwargs`` are given with an instance, or ``spec`` is neither a name nor a
            :class:`Sensor`.
    """
    return SENSOR_REGISTRY.make(spec, **kwargs)
