r"""Continuous refinement of grid controls on an interpolant of the grid utility.

The coordination (:mod:`~infoseek.planners.coordination`) picks each vehicle's control from a
tensor grid of candidate controls (``n`` values per control axis). Once it has finished, the
utility of vehicle ``i`` is known at every grid node against the partners' final plans, and so
are the node controls' predicted tracks over the safety horizon. :class:`GridRefiner` searches
the cell around the grid choice ``u_c`` (``|u - u_c| <= one grid spacing`` per axis, inside the
control bounds) for

.. math::  \max_u \; \hat V(u) - \frac{1}{\beta} P(\hat x(u)),

with :math:`\hat V` and :math:`\hat x` the not-a-knot cubic splines through the node values and
node tracks (tensor products of the 1-D splines for two controls; exact at the nodes), ``P``
the separation penalty of eq. 27 over the horizon against the other vehicles' latest tracks,
and ``beta`` the coordination's last penalty parameter. The search evaluates the objective at
``m`` equally spaced points per axis of the cell (the grid choice is one of them) and keeps the
best; the grid choice is kept unless a point is strictly better. Splines are linear in the node
values, so every sample's interpolation weights are precomputed once per grid node; one
refinement is two small matrix products and one penalty evaluation, with no further MI and no
vehicle-model call.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import interpolate

from infoseek.planners.coordination import horizon_separation_penalty

FloatArray = NDArray[np.float64]

__all__ = ["GridRefiner"]


def _spline_weights(nodes: FloatArray, points: FloatArray) -> FloatArray:
    """``(len(points), len(nodes))`` weights of the not-a-knot cubic spline through ``nodes``."""
    if nodes.size < 2:
        return np.ones((points.size, 1))
    spline = interpolate.CubicSpline(nodes, np.eye(nodes.size), axis=0)
    return np.asarray(spline(points), dtype=np.float64)


class GridRefiner:
    """Refines choices on the tensor grid ``axes[0] x ... x axes[d-1]`` (module docstring).

    Args:
        axes: One (``d = 1``) or two (``d = 2``) increasing arrays of node controls per axis;
            the candidate grid is their ``ij``-ordered tensor product.
        points_per_axis: Search points ``m`` per control axis in a cell (odd, ``>= 3``).
    """

    def __init__(self, axes: list[FloatArray], points_per_axis: int) -> None:
        if len(axes) not in (1, 2):
            raise ValueError(f"GridRefiner supports 1 or 2 control axes, got {len(axes)}")
        if points_per_axis < 3:
            raise ValueError(f"points_per_axis must be >= 3, got {points_per_axis}")
        self.axes = [np.asarray(a, dtype=np.float64) for a in axes]
        self.shape = tuple(a.size for a in self.axes)
        half = points_per_axis // 2
        offsets = np.arange(-half, half + 1) / half  # in grid spacings, 0 included
        per_axis: list[list[tuple[FloatArray, FloatArray]]] = []
        for nodes in self.axes:
            spacing = (nodes[-1] - nodes[0]) / max(nodes.size - 1, 1)
            entries = []
            for node in nodes:
                points = np.unique(np.clip(node + offsets * spacing, nodes[0], nodes[-1]))
                entries.append((points, _spline_weights(nodes, points)))
            per_axis.append(entries)
        # per flat grid index: sample controls (M, d) and weights (M, C)
        self._samples: list[FloatArray] = []
        self._weights: list[FloatArray] = []
        for index in np.ndindex(*self.shape):
            parts = [per_axis[d][index[d]] for d in range(len(self.axes))]
            if len(parts) == 1:
                controls = parts[0][0][:, None]
                weights = parts[0][1]
            else:
                (p0, w0), (p1, w1) = parts
                controls = np.stack(np.meshgrid(p0, p1, indexing="ij"), axis=-1).reshape(-1, 2)
                weights = np.einsum("ac,bd->abcd", w0, w1).reshape(p0.size * p1.size, -1)
            self._samples.append(controls)
            self._weights.append(weights)

    def refine(
        self,
        index: int,
        values: FloatArray,
        tracks: FloatArray,
        other_tracks: FloatArray,
        min_separation: float,
        gamma: float,
        penalty_weight: float,
    ) -> tuple[FloatArray, FloatArray]:
        """The best control in the cell of grid node ``index``.

        Args:
            index: Flat index of the grid choice.
            values: ``(C,)`` utility of every grid node.
            tracks: ``(C, H, 2)`` predicted positions of every grid node's control.
            other_tracks: ``(M, H, 2)`` the other vehicles' latest tracks.
            min_separation: Planning separation of eq. 28.
            gamma: Penalty exponent of eq. 27.
            penalty_weight: ``1 / beta``.

        Returns:
            ``(control (d,), track (H, 2))``: the refined control and its interpolated track
            (the grid node's own when nothing is strictly better).
        """
        samples, weights = self._samples[index], self._weights[index]
        utility = weights @ values
        horizon = tracks.shape[1]
        sample_tracks = (weights @ tracks.reshape(tracks.shape[0], -1)).reshape(-1, horizon, 2)
        penalty = horizon_separation_penalty(sample_tracks, other_tracks, min_separation, gamma)
        objective = utility - penalty_weight * penalty
        centre = int(np.argmin(np.abs(samples - self._node(index)).sum(axis=1)))
        best = int(np.argmax(objective))
        if not objective[best] > objective[centre]:
            return self._node(index), tracks[index]
        return samples[best].copy(), sample_tracks[best]

    def _node(self, index: int) -> FloatArray:
        position = np.unravel_index(index, self.shape)
        return np.array([self.axes[d][position[d]] for d in range(len(self.axes))])
