r"""The beacon likelihood summed over measurements on the cells of a 3-D grid (compiled).

For a grid of beacon hypotheses :math:`(x_c, y_c, \psi_k)` (position cells times orientation
cells) and ``M`` received measurements :math:`z_m` from receivers at :math:`p_m`, the kernel
returns, per active cell, :math:`\sum_{m} \log p(z_m \mid p_m, (x_c, y_c, \psi_k))` with
:math:`\log p` the folded projected-normal density of
:class:`~infoseek.envs.sensors.beacon.BeaconSensor` (its module docstring), capped at
``max_snr`` as the sensor caps it. The arithmetic is the sensor's, step by step (the field
``(H_r, H_psi)`` rotated into the world frame, scaled by ``1 / noise_std``, shrunk to
``max_snr``, projected along and across ``z``; ``log erf`` switching to ``log1p(-erfc)`` above
0.5; the two terms combined as NumPy's ``logaddexp`` combines them), with the C library's
transcendentals: it equals ``BeaconSensor.log_likelihood`` summed over ``m`` to a few units in
the last place (``tests/test_oriented_grid_posterior.py``), not bit for bit (the per-position
part is computed once for all orientations of a position).

The active cells are flat indices ``i * n_psi + k`` (position ``i``, orientation ``k``) in
increasing order, so each position's geometry (distance, direction, ``m / r^3`` to every
receiver) is computed once for its run of orientations.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.envs.sensors.beacon import MIN_DISTANCE

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

__all__ = ["beacon_cell_log_likelihood"]

_INV_PI = 1.0 / math.pi
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)
_SQRT_HALF = math.sqrt(0.5)


@kernel
def _log_density(along: float, across: float) -> float:
    """``log p`` of the folded projected normal from the components ``a, b`` of ``mu`` along
    and across the measured direction (module docstring)."""
    along = abs(along)
    core = math.exp(-0.5 * along * along) * _INV_PI + along * math.erf(along * _SQRT_HALF) * (
        _INV_SQRT_2PI
    )
    return -0.5 * across * across + math.log(core)


@kernel
def _receiver_geometry(
    x: float, y: float, poses: FloatArray, moment: float, geometry: FloatArray
) -> None:
    """Per receiver ``m``: ``(cos phi, sin phi, m / max(r, MIN_DISTANCE)^3)`` of the offset
    from a hypothesis at ``(x, y)`` to the receiver, into ``geometry[m]``."""
    for m in range(poses.shape[0]):
        dx = poses[m, 0] - x
        dy = poses[m, 1] - y
        r = math.hypot(dx, dy)
        if r == 0.0:
            geometry[m, 0], geometry[m, 1] = 1.0, 0.0
        else:
            geometry[m, 0], geometry[m, 1] = dx / r, dy / r
        geometry[m, 2] = moment / max(r, MIN_DISTANCE) ** 3


@kernel
def _cell_log_likelihood(
    geometry: FloatArray,
    cos_a: float,
    sin_a: float,
    cos_z: FloatArray,
    sin_z: FloatArray,
    inv_noise: float,
    max_snr: float,
) -> float:
    """``sum_m log p(z_m | cell)`` for one cell of orientation ``(cos_a, sin_a)``."""
    total = 0.0
    for m in range(geometry.shape[0]):
        cos_phi, sin_phi, scale = geometry[m, 0], geometry[m, 1], geometry[m, 2]
        h_r = (2.0 * scale) * (cos_phi * cos_a + sin_phi * sin_a)
        h_psi = scale * (sin_phi * cos_a - cos_phi * sin_a)
        mu_x = (h_r * cos_phi - h_psi * sin_phi) * inv_noise
        mu_y = (h_r * sin_phi + h_psi * cos_phi) * inv_noise
        if max_snr != math.inf:
            shrink = min(1.0, max_snr / max(math.hypot(mu_x, mu_y), 1e-300))
            mu_x, mu_y = mu_x * shrink, mu_y * shrink
        along = mu_x * cos_z[m] + mu_y * sin_z[m]
        across = mu_x * sin_z[m] - mu_y * cos_z[m]
        total += _log_density(along, across)
    return total


@kernel
def _grid_log_likelihood(
    cells: IntArray,
    n_psi: int,
    position_x: FloatArray,
    position_y: FloatArray,
    cos_psi: FloatArray,
    sin_psi: FloatArray,
    poses: FloatArray,
    z: FloatArray,
    moment: float,
    noise_std: float,
    max_snr: float,
) -> FloatArray:
    """The loop of :func:`beacon_cell_log_likelihood` (arguments checked there)."""
    out = np.empty(cells.shape[0])
    cos_z, sin_z = np.cos(z), np.sin(z)
    geometry = np.empty((poses.shape[0], 3))
    inv_noise = 1.0 / noise_std
    current = -1
    for j in range(cells.shape[0]):
        position, k = cells[j] // n_psi, cells[j] % n_psi
        if position != current:
            _receiver_geometry(position_x[position], position_y[position], poses, moment, geometry)
            current = position
        out[j] = _cell_log_likelihood(
            geometry, cos_psi[k], sin_psi[k], cos_z, sin_z, inv_noise, max_snr
        )
    return out


def beacon_cell_log_likelihood(
    sensor: object,
    cells: IntArray,
    positions: FloatArray,
    psi: FloatArray,
    poses: FloatArray,
    z: FloatArray,
) -> FloatArray:
    """``(C,)`` :math:`\\sum_m \\log p(z_m \\mid p_m, \\text{cell})` of the active ``cells``
    (module docstring).

    Args:
        sensor: The :class:`~infoseek.envs.sensors.beacon.BeaconSensor` (its ``moment``,
            ``noise_std`` and ``max_snr``).
        cells: ``(C,)`` increasing flat indices ``i * len(psi) + k``.
        positions: ``(P, 2)`` position-cell centres.
        psi: ``(K,)`` orientation-cell centres.
        poses: ``(M, 2)`` receiver positions.
        z: ``(M,)`` measured directions.

    Raises:
        ValueError: Arrays of the wrong shape or dtype, or cell indices out of range.
    """
    cells = np.ascontiguousarray(cells)
    if cells.ndim != 1 or cells.dtype != np.intp:
        raise ValueError(f"cells must be a 1-D intp array, got {cells.dtype} {cells.shape}")
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    psi = np.ascontiguousarray(psi, dtype=np.float64)
    if positions.ndim != 2 or positions.shape[1] != 2:
        raise ValueError(f"positions must have shape (P, 2), got {positions.shape}")
    if psi.ndim != 1 or psi.size < 1:
        raise ValueError(f"psi must be a non-empty 1-D array, got shape {psi.shape}")
    if cells.size and (cells[0] < 0 or cells[-1] >= positions.shape[0] * psi.size):
        raise ValueError("cells: an index outside the grid")
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    z = np.ascontiguousarray(z, dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] != 2 or z.shape != (poses.shape[0],):
        raise ValueError(f"poses (M, 2) and z (M,) expected, got {poses.shape} and {z.shape}")
    return _grid_log_likelihood(  # type: ignore[no-any-return]
        cells,
        psi.size,
        np.ascontiguousarray(positions[:, 0]),
        np.ascontiguousarray(positions[:, 1]),
        np.cos(psi),
        np.sin(psi),
        poses,
        z,
        float(sensor.moment),  # type: ignore[attr-defined]
        float(sensor.noise_std),  # type: ignore[attr-defined]
        float(sensor.max_snr),  # type: ignore[attr-defined]
    )
