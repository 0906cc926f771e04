r"""The exact Bayesian posterior of a static 2-D target on a regular grid: a reference for the
particle filters.

The target :math:`\theta` lies in the box :math:`[l_x, h_x) \times [l_y, h_y)` with a uniform
prior (the environments' prior). The box is cut into :math:`n_x \times n_y` equal cells of
sides :math:`h_x, h_y` and area :math:`\Delta A = h_x h_y`, centres :math:`c`. The posterior
density is taken constant on each cell, at its value at the centre (midpoint rule): after the
received measurements :math:`z_1 .. z_M` from poses :math:`x_1 .. x_M`,

.. math::  \log P_c = \sum_{m \le M} \log p(z_m \mid x_m, c) - \log Z, \qquad
    \log Z = \operatorname{logsumexp}_c \sum_{m \le M} \log p(z_m \mid x_m, c),

with :math:`\log p` exactly the filters' likelihood (``config.filter_sensor.log_likelihood``,
the model the particle weights are multiplied by, eq. 4 and 14), summed over the measurements a
belief *received* (its row of the environment's reception matrix), in log space and
renormalised after every update. :math:`P_c` is the posterior mass of cell ``c``; the density is
:math:`P_c / \Delta A` on it. From it:

* **MMSE** :math:`\hat\theta = \sum_c P_c\, c` (exact for the piecewise-constant density);
* **mass within** ``r`` of a point ``q``: :math:`\sum_c P_c\, f_c` with :math:`f_c` the
  fraction of cell ``c`` inside the disk. Cells whose centre is farther than
  :math:`r + \rho` from ``q`` (:math:`\rho = \tfrac12\sqrt{h_x^2 + h_y^2}` the half-diagonal)
  have :math:`f_c = 0`, those nearer than :math:`r - \rho` have :math:`f_c = 1`; for the
  cells in between, :math:`f_c` is the fraction of ``s x s`` sub-cell midpoints inside the
  disk (``subcells = s``, default 16);
* **entropy** of the piecewise-constant density,
  :math:`H = -\sum_c P_c \log(P_c / \Delta A)` (``log`` of the box's area at the prior).

**Discretisation error.** Two approximations, both of second order in the cell size:

* the midpoint rule for each cell's mass: for a smooth density ``p`` and square cells of side
  ``h``, :math:`\int_{cell} p = \Delta A\, p(c) + \tfrac{h^2}{24} \int_{cell} \nabla^2 p +
  O(h^4)`, so the grid's mass of a disk exceeds the true one by about
  :math:`-\tfrac{h^2}{24} \oint \partial_n p` (the correction integrates to 0 over the whole
  plane: the normalisation is unaffected to this order). For an isotropic Gaussian posterior
  holding 0.9 of its mass within ``r`` of its mean (:math:`r^2/\sigma^2 = 2 \ln 10`) that is
  :math:`\tfrac{h^2}{24} \tfrac{r^2}{\sigma^4} e^{-r^2/2\sigma^2} = 0.1 (2 \ln 10)^2
  \tfrac{h^2}{24 r^2} \approx 0.088\, h^2 / r^2`, i.e. :math:`0.9 \cdot 10^{-3}` at ``r = 1``,
  ``h = 0.1`` (the default 400 x 400 cells of a 40 x 40 domain): the grid's time to localise
  is exact unless a trial's mass crosses 0.9 within that margin. A likelihood ridge narrower
  than a cell (a bearing taken within about ``h / sigma`` of the target) is sampled at the
  centres only; its effect on the mass of a disk of radius ``r >> h`` is of the same order;
* the sub-cell sampling of :math:`f_c`: the midpoint rule for the indicator of the disk,
  whose error per boundary cell is at most the fraction of the cell within
  :math:`\rho / s` of the circle, and whose signed errors along the circle average out; at
  ``s = 16`` the disk area :math:`\pi r^2` of a uniform density is met within :math:`10^{-4}`
  relative (test ``test_mass_within_a_uniform_density_is_the_disk_area``).

**Pruning** (``prune``, optional): cells whose log posterior is more than ``prune`` nats
below the largest are dropped for good (they are no longer evaluated; their mass reads 0).
With ``prune >= 700`` the dropped cells' weights underflow float64 anyway (:math:`e^{-700}
\approx 10^{-304}`), so nothing computed at that step changes; a dropped cell could only matter
if later measurements raised it by ``prune`` nats over the mode, and under the model the
probability that the data favour a cell that wrongly by ``prune`` nats is at most
:math:`e^{-\text{prune}}` (Markov's inequality on the likelihood ratio).

The target must be static (no prediction step): this is the posterior of the
``StationaryTarget`` environments. Every operation is vectorised over the cells.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.targets import StationaryTarget

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

__all__ = [
    "DEFAULT_CELLS",
    "DEFAULT_SUBCELLS",
    "GridPosterior",
    "check_cells",
    "check_point",
    "check_positive_int",
    "check_radius",
    "check_update_arrays",
    "disk_mass",
]

#: Cells per axis of :meth:`GridPosterior.from_config` (0.1 units on a 40-unit domain).
DEFAULT_CELLS = 400
#: Sub-cell midpoints per axis of a disk's boundary cells (:meth:`GridPosterior.mass_within`).
DEFAULT_SUBCELLS = 16


class GridPosterior:
    """The exact posterior of a static 2-D target on a regular grid (module docstring).

    Attributes:
        low: ``(2,)`` lower corner of the box.
        high: ``(2,)`` upper corner of the box.
        shape: ``(n_x, n_y)`` cells per axis.
        cell_sides: ``(2,)`` cell sides ``(h_x, h_y)``.
        cell_area: Area of one cell.
        subcells: Sub-cell midpoints per axis of a disk's boundary cells.
        prune: Log-posterior gap below the largest under which a cell is dropped (``None``:
            never).
    """

    def __init__(
        self,
        low: Any,
        high: Any,
        cells: int | tuple[int, int] = DEFAULT_CELLS,
        subcells: int = DEFAULT_SUBCELLS,
        prune: float | None = None,
    ) -> None:
        """A uniform posterior (the prior) over the box ``[low, high)``.

        Args:
            low: ``(2,)`` finite lower corner.
            high: ``(2,)`` finite upper corner, above ``low`` in both coordinates.
            cells: Cells per axis, one integer for both or ``(n_x, n_y)``, each ``>= 2``.
            subcells: Sub-cell midpoints per axis for a disk's boundary cells, ``>= 1``.
            prune: Drop cells more than this many nats below the mode (``> 0``), or ``None``.

        Raises:
            ValueError: An argument out of its range (the message names it).
        """
        self.low = check_point(low, "low")
        self.high = check_point(high, "high")
        if not np.all(self.high > self.low):
            raise ValueError(f"high must exceed low in both coordinates, got {low!r}, {high!r}")
        self.shape = check_cells(cells)
        self.subcells = check_positive_int(subcells, "subcells", 1)
        if prune is not None and not (isinstance(prune, int | float) and prune > 0):
            raise ValueError(f"prune must be a positive number of nats or None, got {prune!r}")
        self.prune = None if prune is None else float(prune)
        self.cell_sides = (self.high - self.low) / np.asarray(self.shape, dtype=np.float64)
        self.cell_area = float(np.prod(self.cell_sides))
        axes = [self.low[i] + (np.arange(self.shape[i]) + 0.5) * self.cell_sides[i] for i in (0, 1)]
        xs, ys = np.meshgrid(*axes, indexing="ij")
        self._centres = np.stack([xs.ravel(), ys.ravel()], axis=1)
        self._active: IntArray = np.arange(self._centres.shape[0], dtype=np.intp)
        self._log = np.full(self._active.size, -math.log(self._active.size))

    @classmethod
    def from_config(
        cls,
        config: Any,
        cells: int | tuple[int, int] = DEFAULT_CELLS,
        subcells: int = DEFAULT_SUBCELLS,
        prune: float | None = None,
    ) -> GridPosterior:
        """The prior over an environment's target domain (``config.space``, 2-D).

        Args:
            config: The environment's ``SearchConfig`` (``env.unwrapped.config``).
            cells: Cells per axis (as for the constructor).
            subcells: Sub-cell midpoints per axis (as for the constructor).
            prune: Pruning gap in nats (as for the constructor).

        Raises:
            ValueError: The target space is not 2-D, or its target moves.
        """
        space = config.space
        if space.dim != 2:
            raise ValueError(f"config: the grid posterior needs a 2-D target, got {space.dim}-D")
        if not isinstance(config.target_motion, StationaryTarget):
            raise ValueError(
                f"config: the grid posterior needs a static target, got {config.target_motion!r}"
            )
        return cls(space.low_array, space.high_array, cells, subcells, prune)

    # ------------------------------------------------------------------------- state
    @property
    def centres(self) -> FloatArray:
        """``(n_x n_y, 2)`` cell centres, x index slowest (read-only)."""
        view = self._centres.view()
        view.flags.writeable = False
        return view

    @property
    def log_posterior(self) -> FloatArray:
        """``(n_x n_y,)`` normalised log posterior mass of every cell (``-inf`` if pruned)."""
        out = np.full(self._centres.shape[0], -np.inf)
        out[self._active] = self._log
        return out

    @property
    def n_active(self) -> int:
        """Cells still evaluated (all of them unless pruned)."""
        return int(self._active.size)

    def _weights(self) -> FloatArray:
        return np.exp(self._log)

    # ------------------------------------------------------------------------- update
    def update(self, sensor: Any, poses: Any, measurements: Any, received: Any) -> float:
        """Multiply in the likelihood of the received measurements and renormalise.

        Args:
            sensor: The filters' likelihood model (``log_likelihood(z, poses, particles)``).
            poses: ``(M, pose_dim)`` poses of the sensors that made the measurements.
            measurements: ``(M, obs_dim)`` measurements.
            received: ``(M,)`` booleans: which measurements this belief received.

        Returns:
            The log evidence :math:`\\log \\sum_c P_c\\, p(z \\mid c)` of the received
            measurements (0.0 when none was received; the posterior is then unchanged).

        Raises:
            TypeError: ``sensor`` has no ``log_likelihood``.
            ValueError: Shapes that do not match, non-finite values, or measurements that
                every cell finds impossible.
        """
        if not callable(getattr(sensor, "log_likelihood", None)):
            raise TypeError(f"sensor must have log_likelihood(z, poses, particles), got {sensor!r}")
        poses, measurements, received = check_update_arrays(poses, measurements, received)
        if not received.any():
            return 0.0
        loglik = np.asarray(
            sensor.log_likelihood(
                measurements[received], poses[received], self._centres[self._active]
            ),
            dtype=np.float64,
        )
        total = self._log + loglik.reshape(-1, self._active.size).sum(axis=0)
        peak = float(np.max(total))
        if not math.isfinite(peak) or np.isnan(total).any():
            raise ValueError("measurements: no cell of the grid can explain them")
        log_z = peak + math.log(float(np.exp(total - peak).sum()))
        self._log = total - log_z
        if self.prune is not None:
            keep = self._log >= (peak - log_z) - self.prune
            self._active, self._log = self._active[keep], self._log[keep]
        return log_z

    # ------------------------------------------------------------------------- summaries
    def mmse(self) -> FloatArray:
        """``(2,)`` posterior mean (module docstring)."""
        return np.asarray(self._weights() @ self._centres[self._active], dtype=np.float64)

    def mass_within(self, radius: float, centre: Any) -> float:
        """Posterior mass of the disk of ``radius`` around ``centre`` (module docstring).

        Args:
            radius: Finite positive radius.
            centre: ``(2,)`` finite centre.

        Raises:
            ValueError: ``radius`` or ``centre`` out of range.
        """
        radius = check_radius(radius)
        q = check_point(centre, "centre")
        points = self._centres[self._active]
        return disk_mass(points, self._weights(), self.cell_sides, self.subcells, radius, q)

    def entropy(self) -> float:
        """Differential entropy (nats) of the piecewise-constant posterior density."""
        weights = self._weights()
        positive = weights > 0
        return float(-(weights[positive] @ self._log[positive]) + math.log(self.cell_area))


def check_radius(radius: Any) -> float:
    """``radius`` as a finite positive float, or a ``ValueError`` naming it."""
    if isinstance(radius, bool) or not isinstance(radius, int | float):
        raise ValueError(f"radius must be a positive number, got {radius!r}")
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be finite and > 0, got {radius!r}")
    return float(radius)


def disk_mass(
    points: FloatArray,
    weights: FloatArray,
    cell_sides: FloatArray,
    subcells: int,
    radius: float,
    centre: FloatArray,
) -> float:
    """Mass of the disk of ``radius`` around ``centre`` of cells of sides ``cell_sides`` with
    centres ``points`` ``(C, 2)`` and masses ``weights`` ``(C,)``: the cells within
    ``radius - rho`` count whole, those in the ring of half-width ``rho`` (the half-diagonal)
    by the fraction of their ``subcells x subcells`` sub-cell midpoints inside (module
    docstring). Arguments are the caller's, already checked."""
    q = centre
    distance = np.hypot(points[:, 0] - q[0], points[:, 1] - q[1])
    rho = 0.5 * float(np.hypot(*cell_sides))
    inside = float(weights[distance <= radius - rho].sum())
    edge = np.flatnonzero((distance > radius - rho) & (distance < radius + rho))
    if edge.size == 0:
        return inside
    s = subcells
    steps = (np.arange(s) + 0.5) / s - 0.5
    dx, dy = np.meshgrid(steps * cell_sides[0], steps * cell_sides[1])
    sub_x = points[edge, 0, None] + dx.ravel()[None, :] - q[0]
    sub_y = points[edge, 1, None] + dy.ravel()[None, :] - q[1]
    fraction = np.mean(sub_x**2 + sub_y**2 <= radius**2, axis=1)
    return inside + float(weights[edge] @ fraction)


def check_point(value: Any, name: str) -> FloatArray:
    """``value`` as a finite ``(2,)`` float array, or a ``ValueError`` naming ``name``."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a (2,) array of numbers, got {value!r}") from None
    if array.shape != (2,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be a finite (2,) array, got {value!r}")
    return array


def check_positive_int(value: Any, name: str, least: int) -> int:
    """``value`` as an ``int >= least``, or a ``ValueError`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
        raise ValueError(f"{name} must be an integer >= {least}, got {value!r}")
    return int(value)


def check_cells(cells: Any) -> tuple[int, int]:
    """``cells`` as ``(n_x, n_y)``, each ``>= 2``."""
    if isinstance(cells, tuple | list):
        if len(cells) != 2:
            raise ValueError(f"cells must be an integer or a pair, got {cells!r}")
        return check_positive_int(cells[0], "cells", 2), check_positive_int(cells[1], "cells", 2)
    n = check_positive_int(cells, "cells", 2)
    return n, n


def check_update_arrays(
    poses: Any, measurements: Any, received: Any
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """The arguments of :meth:`GridPosterior.update`, checked (a ``ValueError`` names the
    first bad one)."""
    poses = np.asarray(poses, dtype=np.float64)
    measurements = np.asarray(measurements, dtype=np.float64)
    if poses.ndim != 2 or not np.all(np.isfinite(poses)):
        raise ValueError(f"poses must be a finite (M, pose_dim) array, got shape {poses.shape}")
    if measurements.ndim != 2 or measurements.shape[0] != poses.shape[0]:
        raise ValueError(
            f"measurements must have shape ({poses.shape[0]}, obs_dim), got {measurements.shape}"
        )
    if not np.all(np.isfinite(measurements)):
        raise ValueError("measurements must be finite")
    flags = np.asarray(received)
    if flags.dtype != np.bool_ or flags.shape != (poses.shape[0],):
        raise ValueError(
            f"received must be a boolean ({poses.shape[0]},) array, got {flags.dtype} {flags.shape}"
        )
    return poses, measurements, flags
