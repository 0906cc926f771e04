"""Per-pose work of one belief stored as rows of contiguous arrays, keyed by the exact pose.

A planner asks one :class:`~infoseek.planners.information.base.BeliefMI` for the MI of the
same few poses many times (a vehicle's candidates in every coordination sweep, the partners'
plans in every pair). :class:`PoseRows` keeps the per-pose work of one kind (e.g. the ``fft``
estimator's predictions, or its window stencils) as rows of a few named arrays, the *banks*,
so that a compiled kernel reads the rows of a pose set in place (no stacking of per-pose
arrays) and a repeated pose costs one dictionary lookup.

Rows are appended (the banks double their capacity as they grow) and never overwritten, so an
array a caller holds keeps the rows it was given. When the banks would exceed their byte
budget they are replaced by empty ones (:attr:`PoseRows.generation` counts the replacements):
rows returned by earlier calls then refer to the old arrays, which the caller still holds, and
callers that cache row numbers across calls compare the generation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import NDArray

__all__ = ["PoseRows"]

Compute = Callable[[NDArray[np.float64]], Mapping[str, NDArray[np.generic]]]


class PoseRows:
    """Rows of per-pose arrays keyed by the exact pose (module docstring).

    Args:
        budget: Bytes the banks may hold; past it they start again empty.
    """

    def __init__(self, budget: int) -> None:
        self._budget = int(budget)
        self._index: dict[bytes, int] = {}
        self._banks: dict[str, NDArray[np.generic]] = {}
        self.size = 0
        self.generation = 0

    @property
    def nbytes(self) -> int:
        """Bytes held by the banks."""
        return sum(int(bank.nbytes) for bank in self._banks.values())

    def bank(self, name: str) -> NDArray[np.generic]:
        """The array ``name`` (its first :attr:`size` rows are filled)."""
        return self._banks[name]

    def lookup(self, poses: NDArray[np.float64], compute: Compute) -> NDArray[np.int64]:
        """Row of each pose, computing the poses not seen before.

        Args:
            poses: ``(P, pose_dim)`` float64 poses.
            compute: ``compute(new_poses) -> {name: array}``, one array per bank with a leading
                axis of ``len(new_poses)``; called once, with the poses not seen before in
                request order (a pose repeated in the request is passed each time and keeps
                the last result: some computations, a BLAS matrix-vector product among them,
                round a row differently in batches of other sizes, so the batches are the
                ones the per-pose code formed).

        Returns:
            ``(P,)`` rows into :meth:`bank` (valid for the arrays :meth:`bank` returns now).
        """
        keys = [pose.tobytes() for pose in poses]
        index = self._index
        rows = [index.get(key, -1) for key in keys]
        if -1 not in rows:
            return np.array(rows, dtype=np.int64)
        missing = [p for p, row in enumerate(rows) if row == -1]
        fresh = compute(poses[missing])
        if self._over_budget(len(missing), fresh):
            self._clear()  # then every pose of the request is new (size 0: no second clear)
            return self.lookup(poses, compute)
        first = self._append(fresh, len(missing))
        for offset, p in enumerate(missing):  # a repeated pose keeps its last row
            index[keys[p]] = first + offset
        return np.array([index[key] for key in keys], dtype=np.int64)

    def _over_budget(self, count: int, fresh: Mapping[str, NDArray[np.generic]]) -> bool:
        if self.size == 0:
            return False
        per_row = sum(int(array.nbytes) // max(count, 1) for array in fresh.values())
        return (self.size + count) * per_row > self._budget

    def _append(self, fresh: Mapping[str, NDArray[np.generic]], count: int) -> int:
        """Append ``count`` rows of every bank; returns the first new row."""
        first = self.size
        if not self._banks:
            self._banks = {name: np.ascontiguousarray(array) for name, array in fresh.items()}
        else:
            capacity = next(iter(self._banks.values())).shape[0]
            if first + count > capacity:
                grown = max(2 * capacity, first + count)
                for name, bank in self._banks.items():
                    larger = np.empty((grown,) + bank.shape[1:], dtype=bank.dtype)
                    larger[:first] = bank[:first]
                    self._banks[name] = larger
            for name, array in fresh.items():
                self._banks[name][first : first + count] = array
        self.size = first + count
        return first

    def _clear(self) -> None:
        self._index = {}
        self._banks = {}
        self.size = 0
        self.generation += 1

    def __repr__(self) -> str:
        return f"PoseRows(size={self.size}, banks={sorted(self._banks)})"
