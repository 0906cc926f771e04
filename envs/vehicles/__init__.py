"""Vehicle models (eq. 1 of Hoffmann, Waslander & Tomlin 2006) and their registry."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from infoseek.envs.registries import Registry
from infoseek.envs.vehicles.airplane import Airplane
from infoseek.envs.vehicles.base import Vehicle
from infoseek.envs.vehicles.quadrotor import Quadrotor

__all__ = ["VEHICLE_REGISTRY", "Airplane", "Quadrotor", "Vehicle", "make_vehicle"]

#: Registry name -> vehicle class (``VEHICLE_REGISTRY.register(name, cls)`` adds one).
VEHICLE_REGISTRY: Registry[Callable[..., Vehicle]] = Registry("vehicle", Vehicle)
VEHICLE_REGISTRY.register("airplane", Airplane)
VEHICLE_REGISTRY.register("quadrotor", Quadrotor)


def make_vehicle(spec: str | Vehicle, **kwargs: Any) -> Vehicle:
    """Build a vehicle model from a registry name, or pass an instance through.

    Args:
        spec: A key of :data:`VEHICLE_REGISTRY` (``"airplane"``, ``"quadrotor"``) or a
            :class:`Vehicle` instance.
        **kwargs: Constructor arguments (only with a registry name).

    Returns:
        The vehicle model.

    Raises:
        ValueError: Unknown registry name (the message lists the valid names).
        TypeError: ``kwargs`` with an instance, or ``spec`` of the wrong type.
    """
    return VEHICLE_REGISTRY.make(spec, **kwargs)
