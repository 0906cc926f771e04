r"""The general estimator: likelihoods on quadrature nodes (any one-dimensional sensor).

The observation domain is covered by ``Q`` equally spaced nodes (periodic domains: ``Q`` nodes
per period, the periodic trapezoid rule, spectrally accurate for smooth periodic integrands;
other domains: ``Q`` nodes from ``low`` to ``high``, the trapezoid rule, whose end nodes carry
negligible mass by the domain's construction). Each particle's likelihood row
``exp(log_likelihood)`` on the nodes is normalised to a probability vector (a softmax in log
space, so no row underflows): a discrete channel (:mod:`~infoseek.planners.information.channels`)
whose MI equals the continuous MI to quadrature accuracy whenever the grid resolves the
likelihoods. Only ``log_likelihood`` is called, so every :class:`~infoseek.envs.sensors.base.Sensor`
is served; the cost is ``O(N Q)`` likelihood evaluations per pose. Default ``Q``: 128 nodes for
one and two observations (one grid for every term of a utility), 40 for three.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from infoseek.envs.sensors.base import ObservationDomain, Sensor
from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.channels import ChannelEstimator

__all__ = ["QuadratureEstimator", "observation_nodes"]

_DEFAULT_NODES = {1: 128, 2: 128, 3: 40}


def observation_nodes(domain: ObservationDomain, n_points: int) -> tuple[FloatArray, float]:
    """Quadrature nodes over a one-dimensional observation domain.

    Args:
        domain: The sensor's domain (``dim == 1``).
        n_points: ``Q``, the number of nodes (>= 2).

    Returns:
        ``(nodes (Q,), spacing)``: for a periodic domain ``low + q * period / Q``; otherwise
        ``Q`` nodes from ``low`` to ``high`` inclusive.
    """
    if domain.dim != 1:
        raise ValueError(f"observation_nodes needs a 1-D domain, got dim={domain.dim}")
    if n_points < 2:
        raise ValueError(f"n_points must be >= 2, got {n_points}")
    low, high = float(domain.low[0]), float(domain.high[0])
    if domain.periodic[0]:
        spacing = (high - low) / n_points
        return low + spacing * np.arange(n_points, dtype=np.float64), spacing
    nodes: FloatArray = np.linspace(low, high, n_points)
    return nodes, (high - low) / (n_points - 1)


def check_points(n_points: object, name: str = "n_points") -> int | None:
    """``None`` or an integer ``>= 2``; ``ValueError`` naming ``name`` otherwise."""
    if n_points is None:
        return None
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer) or n_points < 2:
        raise ValueError(f"{name} must be None or an integer >= 2, got {n_points!r}")
    return int(n_points)


class QuadratureEstimator(ChannelEstimator):
    """Likelihood channels on ``Q`` quadrature nodes (module docstring).

    Args:
        sensor: Any sensor with a one-dimensional observation.
        n_points: Nodes per observation for every ``k`` (``None``: 128 for ``k <= 2``, 40 for
            ``k = 3``).
    """

    name: ClassVar[str] = "quadrature"
    options: ClassVar[tuple[str, ...]] = ("n_points",)

    def __init__(self, sensor: Sensor, n_points: int | None = None) -> None:
        super().__init__(sensor)
        self.n_points = check_points(n_points)

    def cells(self, k: int) -> int:
        return self.n_points if self.n_points is not None else _DEFAULT_NODES[k]

    def log_cell(self, q: int) -> float:
        return float(np.log(observation_nodes(self.sensor.domain, q)[1]))

    def compute_channels(self, poses: FloatArray, particles: FloatArray, q: int) -> FloatArray:
        nodes, _ = observation_nodes(self.sensor.domain, q)
        z = nodes.reshape((1, q, 1))
        log_lik = np.asarray(
            self.sensor.log_likelihood(z, poses[:, None, :], particles), dtype=np.float64
        )  # (P, Q, N)
        log_lik = np.swapaxes(log_lik, -1, -2)
        if np.any(np.isnan(log_lik)):
            raise ValueError("sensor.log_likelihood returned NaN")
        peak = np.max(log_lik, axis=-1, keepdims=True)
        peak = np.where(np.isfinite(peak), peak, 0.0)
        rows = np.exp(log_lik - peak)
        sums = rows.sum(axis=-1, keepdims=True)
        # A particle whose likelihood vanishes on every node carries no usable channel; it is
        # treated as uninformative (uniform row) rather than propagating NaN.
        return np.where(sums > 0, rows / np.where(sums > 0, sums, 1.0), 1.0 / q)
