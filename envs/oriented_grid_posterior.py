r"""The exact Bayesian posterior of a static planar target with an orientation on a regular 3-D
grid: a reference for the beacon's particle filters.

The target :math:`\theta = (x, y, \psi)` lies in :math:`[l_x, h_x) \times [l_y, h_y) \times
[0, 2\pi)` with a uniform prior (``beacon_v0``'s ``TargetSpace.planar_with_orientation``), the
angle :math:`\psi` periodic. The box is cut into :math:`n_x \times n_y` position cells of sides
:math:`h_x, h_y` (as :mod:`infoseek.envs.grid_posterior`) times :math:`n_\psi` orientation cells
of width :math:`h_\psi = P / n_\psi` over one period :math:`[0, P)` of the grid, centres
:math:`c = (x_c, y_c, \psi_c)`. The posterior is constant on each cell at its centre's value
(midpoint rule): after received measurements :math:`z_1 .. z_M` from poses :math:`p_1 .. p_M`,

.. math::  \log P_c = \sum_{m \le M} \log p(z_m \mid p_m, c) - \log Z,

exactly as in 2-D (:mod:`infoseek.envs.grid_posterior`: the filters' likelihood, the
received measurements only, log space, renormalised after every update).

**Why half the circle suffices for an axial angle.** The beacon's field is linear in
:math:`(\cos\psi, \sin\psi)` (``BeaconSensor``: :math:`H_r \propto \cos(\phi - \psi)`,
:math:`H_\psi \propto \sin(\phi - \psi)`), so :math:`\psi \to \psi + \pi` flips the field's sign,
and the folded density depends on the field only through :math:`|a|` and :math:`b^2`
(``test_the_beacon_likelihood_is_axial``). With the uniform prior the posterior on
:math:`[0, 2\pi)` is then :math:`\pi`-periodic: its restriction to :math:`[0, \pi)`, times 2, is the
posterior of :math:`\psi \bmod \pi`, and the position marginal is the same. For a coordinate the
target space marks ``axial`` the grid covers :math:`P = \pi` (half the period); otherwise the whole
period.

From the posterior:

* the **position marginal** :math:`P_{xy} = \sum_\psi P_c`, and from it the **mass within** ``r``
  of a point (:func:`~infoseek.envs.grid_posterior.disk_mass`, the 2-D rule: whole cells inside,
  ``s x s`` sub-cell midpoints for the boundary cells) and the **entropy**;
* the **MMSE position** :math:`\sum_c P_c (x_c, y_c)`;
* the **orientation estimate**, the circular mean on the grid's period:
  :math:`\hat\psi = \tfrac{P}{2\pi} \arg \sum_c P_c e^{2\pi i \psi_c / P}` in :math:`[0, P)` (for
  the axial beacon, the axial mean: doubled angles averaged, halved, as the filters report it).

**Discretisation error.** In position, the 2-D module's analysis holds for the marginal
(:math:`\approx 0.088\, h^2 / r^2` on a mass near 0.9 for a Gaussian, :math:`0.9 \cdot 10^{-3}`
at ``h = 0.1``, ``r = 1``). In :math:`\psi` the midpoint rule on a periodic coordinate is the
trapezoidal rule of a periodic function, whose error for a smooth integrand falls faster than any
power of :math:`h_\psi`: for a Gaussian factor of standard deviation :math:`\sigma_\psi` it is
about :math:`2 e^{-2\pi^2 \sigma_\psi^2 / h_\psi^2}`. One floored beacon reading (``max_snr``
5: angular standard deviation ``>= 0.2`` rad in the field line, so ``>= 0.1`` rad in
:math:`\psi`, whose field line turns at most twice as fast) has :math:`\sigma_\psi / h_\psi \ge
2` at :math:`h_\psi = \pi / 64`, an error below :math:`10^{-30}`; many readings of one place
sharpen the posterior in :math:`\psi` below a cell, and then, as a bearing ridge narrower than a
cell in 2-D, it is sampled at the centres. **Measured** (``infoseek reproduce beacon_grid
--halved-cells``, three stored ``beacon_v0`` pairwise episodes, every step): halving every cell
(0.05 units, :math:`\pi/128`; eight times the cells) moves the mass within 1 unit of the MMSE
by at most 0.0024 (mean 0.00004) and no time to localise; the MMSE position moves by up to
0.06 units, because once the posterior is narrower than a cell the MMSE is a mean of a few cell
centres, whose distance to the target (0.038 units on average at ``h = 0.1``) is a floor of the
grid: MMSE errors below about 0.07 units are the grid's, not the posterior's.

**Pruning** as in 2-D: cells more than ``prune`` nats below the mode are dropped for good; the
dropped mass at that step is at most :math:`n\, e^{-\text{prune}}` (``n`` cells), and a
dropped cell could matter later only if the data came to favour it by ``prune`` nats over the
mode, of probability at most :math:`e^{-\text{prune}}` under the model. The beacon's far-field
readings are nearly flat (a reading moves a far cell by at most about 1.8 nats against the
mode), so a gap of 700 nats is rarely reached in an episode; smaller gaps (``prune = 50``:
dropped mass below :math:`10^{-14}` on ten million cells, the beacon study's choice, under
which the true target's cell stayed active in every rerun episode) keep the cost down once the
posterior concentrates.

The target must be static. The likelihood is evaluated by a compiled kernel for
:class:`~infoseek.envs.sensors.beacon.BeaconSensor` (:mod:`infoseek.envs.beacon_grid_kernel`,
the sensor's density to rounding) and, for any other sensor of a 3-D target, by its own
``log_likelihood`` in blocks of cells.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.beacon_grid_kernel import beacon_cell_log_likelihood
from infoseek.envs.grid_posterior import (
    DEFAULT_CELLS,
    DEFAULT_SUBCELLS,
    check_cells,
    check_point,
    check_positive_int,
    check_radius,
    check_update_arrays,
    disk_mass,
)
from infoseek.envs.sensors.beacon import BeaconSensor
from infoseek.envs.targets import StationaryTarget

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

__all__ = ["DEFAULT_ORIENTATION_CELLS", "OrientedGridPosterior"]

#: Orientation cells of :meth:`OrientedGridPosterior.from_config` (``pi / 64`` on ``[0, pi)``).
DEFAULT_ORIENTATION_CELLS = 64
#: Cells per block when a sensor's own ``log_likelihood`` is evaluated.
_BLOCK = 1 << 16


class OrientedGridPosterior:
    """The exact posterior of a static ``(x, y, psi)`` target on a regular grid (module
    docstring).

    Attributes:
        low: ``(2,)`` lower corner of the position box.
        high: ``(2,)`` upper corner of the position box.
        shape: ``(n_x, n_y, n_psi)`` cells per axis.
        period: The grid's orientation period ``P`` (cells cover ``[0, P)``).
        cell_sides: ``(3,)`` cell sides ``(h_x, h_y, h_psi)``.
        cell_volume: Volume of one cell.
        subcells: Sub-cell midpoints per axis of a disk's boundary cells.
        prune: Log-posterior gap below the mode under which a cell is dropped (``None``: never).
    """

    def __init__(
        self,
        low: Any,
        high: Any,
        cells: int | tuple[int, int] = DEFAULT_CELLS,
        orientation_cells: int = DEFAULT_ORIENTATION_CELLS,
        period: float = math.pi,
        subcells: int = DEFAULT_SUBCELLS,
        prune: float | None = None,
    ) -> None:
        """A uniform posterior (the prior) over ``[low, high) x [0, period)``.

        Args:
            low: ``(2,)`` finite lower corner of the position box.
            high: ``(2,)`` finite upper corner, above ``low`` in both coordinates.
            cells: Position cells per axis, one integer or ``(n_x, n_y)``, each ``>= 2``.
            orientation_cells: Orientation cells ``n_psi >= 2``.
            period: The orientation period the grid covers (finite, ``> 0``; ``pi`` for an
                axial angle).
            subcells: Sub-cell midpoints per axis for a disk's boundary cells, ``>= 1``.
            prune: Drop cells more than this many nats below the mode (``> 0``), or ``None``.

        Raises:
            ValueError: An argument out of its range (the message names it).
        """
        self.low = check_point(low, "low")
        self.high = check_point(high, "high")
        if not np.all(self.high > self.low):
            raise ValueError(f"high must exceed low in both coordinates, got {low!r}, {high!r}")
        n_x, n_y = check_cells(cells)
        n_psi = check_positive_int(orientation_cells, "orientation_cells", 2)
        if isinstance(period, bool) or not isinstance(period, int | float):
            raise ValueError(f"period must be a positive number, got {period!r}")
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0, got {period!r}")
        self.period = float(period)
        self.shape = (n_x, n_y, n_psi)
        self.subcells = check_positive_int(subcells, "subcells", 1)
        if prune is not None and not (isinstance(prune, int | float) and prune > 0):
            raise ValueError(f"prune must be a positive number of nats or None, got {prune!r}")
        self.prune = None if prune is None else float(prune)
        sides = (self.high - self.low) / np.array([n_x, n_y], dtype=np.float64)
        self.cell_sides = np.append(sides, self.period / n_psi)
        self.cell_volume = float(np.prod(self.cell_sides))
        axes = [self.low[i] + (np.arange(self.shape[i]) + 0.5) * sides[i] for i in (0, 1)]
        xs, ys = np.meshgrid(*axes, indexing="ij")
        self._positions = np.stack([xs.ravel(), ys.ravel()], axis=1)
        self._psi = (np.arange(n_psi) + 0.5) * self.cell_sides[2]
        self._active: IntArray = np.arange(self._positions.shape[0] * n_psi, dtype=np.intp)
        self._log = np.full(self._active.size, -math.log(self._active.size))
        self._cached_weights: FloatArray | None = None

    @classmethod
    def from_config(
        cls,
        config: Any,
        cells: int | tuple[int, int] = DEFAULT_CELLS,
        orientation_cells: int = DEFAULT_ORIENTATION_CELLS,
        subcells: int = DEFAULT_SUBCELLS,
        prune: float | None = None,
    ) -> OrientedGridPosterior:
        """The prior over an environment's target domain (``config.space``: ``(x, y, psi)``
        with ``psi`` periodic on ``[0, 2 pi)``; half of it if ``psi`` is axial).

        Raises:
            ValueError: The target space is not such a space, or the target moves.
        """
        space = config.space
        if space.dim != 3 or not space.periodic[2]:
            raise ValueError(
                f"config: the oriented grid posterior needs an (x, y, angle) target, got {space!r}"
            )
        if space.low[2] != 0.0:
            raise ValueError(f"config: the angle must start at 0, got {space.low[2]!r}")
        if not isinstance(config.target_motion, StationaryTarget):
            raise ValueError(
                f"config: the grid posterior needs a static target, got {config.target_motion!r}"
            )
        period = float(space.high[2]) / (2.0 if space.axial[2] else 1.0)
        low, high = space.low_array[:2], space.high_array[:2]
        return cls(low, high, cells, orientation_cells, period, subcells, prune)

    # ------------------------------------------------------------------------- state
    @property
    def positions(self) -> FloatArray:
        """``(n_x n_y, 2)`` position-cell centres, x index slowest (read-only)."""
        view = self._positions.view()
        view.flags.writeable = False
        return view

    @property
    def orientations(self) -> FloatArray:
        """``(n_psi,)`` orientation-cell centres in ``[0, period)`` (read-only)."""
        view = self._psi.view()
        view.flags.writeable = False
        return view

    @property
    def log_posterior(self) -> FloatArray:
        """``(n_x, n_y, n_psi)`` normalised log posterior mass of every cell (``-inf`` if
        pruned)."""
        out = np.full(int(np.prod(self.shape)), -np.inf)
        out[self._active] = self._log
        return out.reshape(self.shape)

    @property
    def n_active(self) -> int:
        """Cells still evaluated (all of them unless pruned)."""
        return int(self._active.size)

    def _weights(self) -> FloatArray:
        """``(C,)`` posterior masses of the active cells (computed once per update)."""
        if self._cached_weights is None:
            self._cached_weights = np.exp(self._log)
        return self._cached_weights

    def cell_of(self, state: Any) -> tuple[int, int, int]:
        """The index ``(i_x, i_y, i_psi)`` of the cell holding ``state = (x, y, psi)`` (``psi``
        taken modulo the period; a position outside the box raises ``ValueError``)."""
        values = np.asarray(state, dtype=np.float64)
        if values.shape != (3,) or not np.all(np.isfinite(values)):
            raise ValueError(f"state must be a finite (3,) array, got {state!r}")
        if not (np.all(values[:2] >= self.low) and np.all(values[:2] < self.high)):
            raise ValueError(f"state: the position {values[:2]} is outside the grid's box")
        index = np.floor((values[:2] - self.low) / self.cell_sides[:2]).astype(int)
        k = int((values[2] % self.period) // self.cell_sides[2])
        shape = self.shape
        return (
            min(int(index[0]), shape[0] - 1),
            min(int(index[1]), shape[1] - 1),
            min(k, shape[2] - 1),
        )

    def _cell_states(self, cells: IntArray) -> FloatArray:
        """``(C, 3)`` centres ``(x, y, psi)`` of the flat cell indices ``cells``."""
        n_psi = self.shape[2]
        return np.column_stack([self._positions[cells // n_psi], self._psi[cells % n_psi]])

    # ------------------------------------------------------------------------- update
    def update(self, sensor: Any, poses: Any, measurements: Any, received: Any) -> float:
        """Multiply in the likelihood of the received measurements and renormalise (as
        :meth:`infoseek.envs.grid_posterior.GridPosterior.update`).

        Args:
            sensor: The filters' likelihood model (``log_likelihood(z, poses, particles)`` with
                ``(x, y, psi)`` particles; a ``BeaconSensor`` runs the compiled kernel).
            poses: ``(M, pose_dim)`` poses of the sensors that made the measurements.
            measurements: ``(M, obs_dim)`` measurements.
            received: ``(M,)`` booleans: which measurements this belief received.

        Returns:
            The log evidence of the received measurements (0.0 when none was received).

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
        loglik = self._log_likelihood(sensor, poses[received], measurements[received])
        total = self._log + loglik
        peak = float(np.max(total))
        if not math.isfinite(peak) or np.isnan(total).any():
            raise ValueError("measurements: no cell of the grid can explain them")
        log_z = peak + math.log(float(np.exp(total - peak).sum()))
        self._log = total - log_z
        self._cached_weights = None
        if self.prune is not None:
            keep = self._log >= (peak - log_z) - self.prune
            self._active, self._log = self._active[keep], self._log[keep]
        return log_z

    def _log_likelihood(self, sensor: Any, poses: FloatArray, measurements: FloatArray) -> Any:
        """``(C,)`` summed log-likelihood of the measurements at every active cell."""
        if isinstance(sensor, BeaconSensor):
            if poses.shape[1] != 2 or measurements.shape[1] != 1:
                raise ValueError(
                    f"poses (M, 2) and measurements (M, 1) expected for {sensor!r}, got "
                    f"{poses.shape} and {measurements.shape}"
                )
            return beacon_cell_log_likelihood(
                sensor, self._active, self._positions, self._psi, poses, measurements[:, 0]
            )
        out = np.empty(self._active.size)
        for start in range(0, self._active.size, _BLOCK):
            block = self._active[start : start + _BLOCK]
            loglik = sensor.log_likelihood(measurements, poses, self._cell_states(block))
            out[start : start + block.size] = np.asarray(loglik, dtype=np.float64).sum(axis=0)
        return out

    # ------------------------------------------------------------------------- summaries
    def _position_marginal(self) -> tuple[IntArray, FloatArray]:
        """The position cells holding an active cell (increasing) and their marginal masses
        (the active cells are sorted, so each position's cells are one run)."""
        positions = self._active // self.shape[2]
        starts = np.flatnonzero(np.diff(positions, prepend=-1))
        return positions[starts], np.add.reduceat(self._weights(), starts)

    def position_marginal(self) -> FloatArray:
        """``(n_x, n_y)`` posterior mass of every position cell (summed over ``psi``)."""
        held, mass = self._position_marginal()
        out = np.zeros(self._positions.shape[0])
        out[held] = mass
        return out.reshape(self.shape[:2])

    def orientation_marginal(self) -> FloatArray:
        """``(n_psi,)`` posterior mass of every orientation cell (summed over positions)."""
        psi = self._active % self.shape[2]
        mass = np.bincount(psi, weights=self._weights(), minlength=self.shape[2])
        return np.asarray(mass, dtype=np.float64)

    def mmse(self) -> FloatArray:
        """``(3,)`` MMSE position and circular-mean orientation (module docstring), from the
        two marginals."""
        held, mass = self._position_marginal()
        position = mass @ self._positions[held]
        psi_mass = self.orientation_marginal()
        angle = (2.0 * math.pi / self.period) * self._psi
        mean = math.atan2(float(psi_mass @ np.sin(angle)), float(psi_mass @ np.cos(angle)))
        psi = (mean * self.period / (2.0 * math.pi)) % self.period
        psi = 0.0 if psi >= self.period else psi  # the modulo of a tiny negative angle
        return np.array([position[0], position[1], psi], dtype=np.float64)

    def mass_within(self, radius: float, centre: Any) -> float:
        """Posterior mass of the position disk of ``radius`` around ``centre`` (``(2,)``), any
        orientation (module docstring).

        Raises:
            ValueError: ``radius`` or ``centre`` out of range.
        """
        radius = check_radius(radius)
        q = check_point(centre, "centre")
        held, mass = self._position_marginal()
        points = self._positions[held]
        return disk_mass(points, mass, self.cell_sides[:2], self.subcells, radius, q)

    def entropy(self) -> float:
        """Differential entropy (nats) of the piecewise-constant density on the grid's box
        ``[low, high) x [0, period)`` (for an axial angle on the whole circle, add ``log 2``)."""
        weights = self._weights()
        positive = weights > 0
        return float(-(weights[positive] @ self._log[positive]) + math.log(self.cell_volume))
