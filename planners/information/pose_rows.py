"""Per-pose work of one belief kept in the blocks it was computed in, keyed by the exact pose.

A planner asks one :class:`~infoseek.planners.information.base.BeliefMI` for the MI of the
same few poses many times (a vehicle's candidates in every coordination sweep, the partners'
plans in every pair). :class:`PoseRows` keeps the per-pose work of one kind (the ``fft``
estimator's predictions or window stencils, the ``fourier`` estimator's spectra or channels)
as the arrays ``compute`` returned for each batch of new poses (*blocks*, never copied), and
hands a pose set back as a view of one block when its poses were computed together and in
order (a vehicle's candidates), else as a gathered copy. A repeated pose costs one dictionary
lookup.

When the blocks would exceed their byte budget they are dropped (:attr:`PoseRows.generation`
counts the drops) and the request is computed again from scratch; arrays handed out before
stay valid (they are the old blocks, or copies).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import NDArray

__all__ = ["PoseRows"]

Compute = Callable[[NDArray[np.float64]], Mapping[str, NDArray[np.generic]]]
#: ``(block, offset)`` of every pose of a request.
Rows = list[tuple[int, int]]


class PoseRows:
    """Per-pose arrays keyed by the exact pose (module docstring).

    Args:
        budget: Bytes the blocks may hold; past it they are dropped and computing starts again.
    """

    def __init__(self, budget: int) -> None:
        self._budget = int(budget)
        self._index: dict[bytes, tuple[int, int]] = {}
        self._blocks: list[Mapping[str, NDArray[np.generic]]] = []
        self.nbytes = 0
        self.generation = 0

    def lookup(self, poses: NDArray[np.float64], compute: Compute) -> Rows:
        """``(block, offset)`` of each pose, computing the poses not seen before.

        Args:
            poses: ``(P, pose_dim)`` float64 poses.
            compute: ``compute(new_poses) -> {name: array}``, one array per kind with a leading
                axis of ``len(new_poses)``; called once, with the poses not seen before in
                request order (a pose repeated in the request is passed each time and keeps
                the last result: some computations, a BLAS matrix-vector product among them,
                round a row differently in batches of other sizes, so the batches are the
                ones the per-pose code formed).

        Returns:
            The rows, for :meth:`take`.
        """
        keys = [pose.tobytes() for pose in poses]
        index = self._index
        found = [index.get(key) for key in keys]
        missing = [p for p, row in enumerate(found) if row is None]
        if not missing:
            return found  # type: ignore[return-value]
        fresh = compute(poses[missing])
        size = sum(int(array.nbytes) for array in fresh.values())
        if self._blocks and self.nbytes + size > self._budget:
            self._index, self._blocks, self.nbytes = {}, [], 0
            self.generation += 1
            return self.lookup(poses, compute)  # every pose is new now: no second drop
        block = len(self._blocks)
        self._blocks.append(fresh)
        self.nbytes += size
        for offset, p in enumerate(missing):  # a repeated pose keeps its last row
            index[keys[p]] = (block, offset)
        return [index[key] for key in keys]

    def take(self, name: str, rows: Rows) -> NDArray[np.generic]:
        """The ``name`` arrays of ``rows`` stacked: a view of one block when the rows are
        consecutive rows of it, else a copy."""
        return self.take_all((name,), rows)[0]

    def take_all(self, names: tuple[str, ...], rows: Rows) -> list[NDArray[np.generic]]:
        """:meth:`take` of several kinds of the same rows."""
        if rows:
            block, first = rows[0]
            last = first + len(rows) - 1
            if rows[-1] == (block, last) and rows == [(block, o) for o in range(first, last + 1)]:
                arrays = self._blocks[block]
                return [arrays[name][first : last + 1] for name in names]
        return [
            np.stack([self._blocks[block][name][offset] for block, offset in rows])
            for name in names
        ]

    def __repr__(self) -> str:
        return f"PoseRows(blocks={len(self._blocks)}, nbytes={self.nbytes})"
