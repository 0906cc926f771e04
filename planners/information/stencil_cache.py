"""The ``fft`` estimator's per-belief work: predictions and window stencils of every pose seen.

One :class:`StencilCache` belongs to one :class:`~infoseek.planners.information.base.BeliefMI`
(it lives in the belief's cache, so it lives exactly as long as the belief). It keeps

* the float32 particles, once;
* the float32 noise-free predictions ``(N,)`` of every pose asked for, in one
  :class:`~infoseek.planners.information.pose_rows.PoseRows` (computed by ``sensor.predict``
  for the new poses of a request, in one call);
* the window stencils (:mod:`~infoseek.planners.information.windows`) of every pose asked for
  in a pair, in a second one (computed by the compiled
  :func:`~infoseek.planners.information.window_stencils.pose_windows` from the predictions);
* one :class:`~infoseek.planners.information.windows.WindowSide` per pose set (its dense
  stencil matrices are built once per set: a vehicle's candidates are one set for the whole
  coordination).

A pose set computed together (a vehicle's candidates) is a view of its block. Everything is
computed exactly as the per-pose code it replaces, so the values do not depend on what was
cached before.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information.base import CACHE_BYTES, FloatArray
from infoseek.planners.information.noise_kernel import NoiseKernel
from infoseek.planners.information.pose_rows import PoseRows
from infoseek.planners.information.window_stencils import pose_windows
from infoseek.planners.information.windows import WindowSide

__all__ = ["StencilCache"]

_WINDOW_KINDS = ("start", "targets", "weights", "widths")


class StencilCache:
    """Predictions and window stencils of one belief (module docstring).

    Args:
        sensor: An additive-noise sensor (``predict``).
        kernel: The estimator's noise kernel.
        particles: ``(N, d)`` float64 particles.
    """

    def __init__(self, sensor: Sensor, kernel: NoiseKernel, particles: FloatArray) -> None:
        self.sensor = sensor
        self.kernel = kernel
        self.particles32 = np.ascontiguousarray(particles, dtype=np.float32)
        self.prediction_table = PoseRows(CACHE_BYTES // 2)
        self.window_table = PoseRows(CACHE_BYTES // 4)
        self._sides: dict[bytes, WindowSide] = {}
        self._sides_generation = 0

    @property
    def nbytes(self) -> int:
        """Bytes held."""
        sides = sum(side.nbytes for side in self._sides.values())
        return self.prediction_table.nbytes + self.window_table.nbytes + sides

    # -- predictions
    def _predict(self, poses: FloatArray) -> dict[str, NDArray[Any]]:
        predicted = np.asarray(
            self.sensor.predict(poses.astype(np.float32), self.particles32)  # type: ignore[attr-defined]
        )
        expected = (poses.shape[0], self.particles32.shape[0], 1)
        if predicted.shape != expected:
            raise ValueError(
                f"sensor.predict returned shape {predicted.shape}, expected {expected}"
            )
        if np.isnan(predicted).any():
            raise ValueError("sensor.predict returned NaN")
        return {"predictions": predicted[..., 0]}

    def predictions(self, poses: FloatArray) -> NDArray[Any]:
        """``(P, N)`` predictions of ``poses`` (float32 for a sensor with a float32 path)."""
        rows = self.prediction_table.lookup(poses, self._predict)
        return self.prediction_table.take("predictions", rows)

    # -- windows
    def _windows(self, poses: FloatArray) -> dict[str, NDArray[Any]]:
        predictions = np.asarray(self.predictions(poses), dtype=np.float32)
        kernel = self.kernel
        start, targets, weights, widths = pose_windows(
            predictions, kernel.low, kernel.spacing, kernel.n_points, kernel.periodic
        )
        return {"start": start, "targets": targets, "weights": weights, "widths": widths}

    def sides(self, *pose_sets: FloatArray) -> list[WindowSide]:
        """The :class:`WindowSide` of each pose set (cached per set)."""
        table = self.window_table
        if self._sides_generation != table.generation:
            self._sides, self._sides_generation = {}, table.generation
        keys = [poses.tobytes() for poses in pose_sets]
        missing = [p for p, key in enumerate(keys) if key not in self._sides]
        if missing:
            found = table.lookup(np.concatenate([pose_sets[p] for p in missing]), self._windows)
            if self._sides_generation != table.generation:  # the blocks were dropped
                self._sides, self._sides_generation = {}, table.generation
                return self.sides(*pose_sets)
            offset = 0
            for p in missing:
                rows = found[offset : offset + pose_sets[p].shape[0]]
                offset += len(rows)
                start, targets, weights, widths = table.take_all(_WINDOW_KINDS, rows)
                self._sides[keys[p]] = WindowSide(
                    self.kernel,
                    start,  # type: ignore[arg-type]
                    targets,  # type: ignore[arg-type]
                    weights,  # type: ignore[arg-type]
                    widths,  # type: ignore[arg-type]
                )
        return [self._sides[key] for key in keys]
