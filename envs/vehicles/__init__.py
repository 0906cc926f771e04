"""Vehicle models (eq. 1 of Hoffmann, Waslander & Tomlin 2006) and their registry."""

from __future__ import annotations

from typing import Any

from infoseek.envs.vehicles.airplane import Airplane
from infoseek.envs.vehicles.base import Vehicle
from infoseek.envs.vehicles.quadrotor import Quadrotor

__all__ = ["VEHICLE_REGISTRY", "Airplane", "Quadrotor", "Vehicle", "make_vehicle"]

VEHICLE_REGISTRY: dict[str, type] = {"airplane": Airplane, "quadrotor": Quadrotor}


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
    if isinstance(spec, str):
        if spec not in VEHICLE_REGISTRY:
            raise ValueError(
                f"spec: unknown vehicle {spec!r}; valid names: {sorted(VEHICLE_REGISTRY)}"
            )
        return VEHICLE_REGISTRY[spec](**kwargs)
    if isinstance(spec, Vehicle):
        if kwargs:
            raise TypeError(
                f"make_vehicle: keyword arguments {sorted(kwargs)} are not allowed with an "
                "instance spec"
            )
        return spec
    raise TypeError(f"spec must be a vehicle name or a Vehicle instance, got {type(spec).__name__}")
