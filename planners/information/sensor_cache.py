"""Per-sensor tables of the estimators, built once per sensor object.

An estimator's tables depend on the sensor model alone: the ``fft`` estimator's discretised
noise density and its spectrum (:class:`~infoseek.planners.information.noise_kernel.
NoiseKernel`). Building one evaluates the noise density on thousands of points, so a one-off
call such as :func:`~infoseek.planners.information.mutual_information_batch`, which builds a new
estimator every time, would spend a sixth of a 64-pose evaluation on it. :func:`sensor_table`
keeps each table with the sensor object it was built for (weakly: the entry goes when the sensor
does), so every estimator of that sensor shares it. The sensors compute their constants at
construction and are not changed afterwards (the filters rely on that too), so a table built
for a sensor stays valid for it; a sensor that cannot be weakly referenced or hashed simply gets
a new table every time.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

__all__ = ["sensor_table"]

T = TypeVar("T")

_TABLES: weakref.WeakKeyDictionary[Any, dict[Hashable, Any]] = weakref.WeakKeyDictionary()


def sensor_table(sensor: Any, key: Hashable, build: Callable[[], T]) -> T:
    """``build()`` for ``sensor`` and ``key``, built once per sensor object.

    Args:
        sensor: The sensor model the table describes.
        key: What else the table depends on (e.g. ``("noise", n_points)``).
        build: Builds the table.
    """
    try:
        tables = _TABLES.setdefault(sensor, {})
    except TypeError:  # not weakly referenceable or not hashable
        return build()
    if key not in tables:
        tables[key] = build()
    return tables[key]  # type: ignore[no-any-return]
