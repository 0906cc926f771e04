"""Sensor models (eq. 3): bearings-only, range, and the avalanche-rescue beacon.

Every model implements :class:`~infoseek.envs.sensors.base.Sensor`; the bearing and range
sensors also implement :class:`~infoseek.envs.sensors.base.AdditiveNoiseSensor`. All three also
offer ``bin_probabilities(edges, poses, particles) -> (..., N, Q)``, the exact probability of
each observation bin, for mutual-information quadrature with likelihoods narrower than any grid.

Use :func:`make_sensor` to build one from a registry name (see :data:`SENSOR_REGISTRY`).
"""

from __future__ import annotations

from typing import Any

from infoseek.envs.sensors.base import AdditiveNoiseSensor, ObservationDomain, Sensor
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
    "make_sensor",
]

#: Registry name -> sensor class.
SENSOR_REGISTRY: dict[str, type] = {
    BearingSensor.name: BearingSensor,
    BeaconSensor.name: BeaconSensor,
    RangeSensor.name: RangeSensor,
}


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
    if isinstance(spec, str):
        try:
            cls = SENSOR_REGISTRY[spec]
        except KeyError:
            raise ValueError(
                f"make_sensor: unknown sensor {spec!r}; valid names: {sorted(SENSOR_REGISTRY)}"
            ) from None
        return cls(**kwargs)
    if isinstance(spec, Sensor):
        if kwargs:
            raise TypeError(
                "make_sensor: keyword arguments are only allowed with a registry name, got "
                f"{sorted(kwargs)} together with an instance of {type(spec).__name__}"
            )
        return spec
    raise TypeError(
        f"make_sensor: spec must be a registry name or a Sensor instance, got {type(spec).__name__}"
    )
