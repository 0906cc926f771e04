"""The observations each belief of a batch has conditioned on since it was drawn from the prior.

For a stationary target the exact posterior of belief ``k`` after ``t`` updates is known up to
a constant without its particles:

    p(theta | z_{1..t}) ~ p_0(theta) prod_{s <= t} prod_{j in R_s(k)} p(z_s^{(j)} | theta),

with ``p_0`` the uniform prior and ``R_s(k)`` the observations of step ``s`` that belief ``k``
received (and kept: an update dropped as impossible is not part of it). Progressive correction
uses it as the target of its Metropolis moves (:mod:`infoseek.envs.belief`, "resample-move" for
a static parameter: Gilks & Berzuini 2001; Chopin 2002). :class:`ObservationHistory` stores one
entry per update of the batch: its sensor model, ``z`` ``(G, M, obs_dim)``, ``poses``
``(G, M, pose_dim)`` and ``received`` ``(K, M)`` (belief ``k`` belongs to group
``k // (K / G)``), so that recording costs one copy per step whatever ``K``; a belief's own
observations are gathered only when a move needs them (and a batch records nothing when its
updates cannot run moves). Memory grows with the episode length
(``O(T G M)`` numbers), which is what an exact static-target posterior needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = ["ObservationHistory"]


@dataclass
class _Entry:
    sensor: Any
    z: FloatArray
    poses: FloatArray
    received: BoolArray


class ObservationHistory:
    """Per-update records of a batch's observations and of which belief kept which.

    Args:
        n_beliefs: Number of beliefs ``K`` of the batch.
    """

    def __init__(self, n_beliefs: int) -> None:
        self._entries: list[_Entry] = []
        self._first = 0  # global index of self._entries[0]
        self._start = np.zeros(int(n_beliefs), dtype=np.int64)  # each row's first entry

    @property
    def n_beliefs(self) -> int:
        """Number of beliefs ``K``."""
        return int(self._start.size)

    def append(self, sensor: Any, z: FloatArray, poses: FloatArray, received: BoolArray) -> None:
        """Record one update: its sensor model, ``(G, M, ...)`` observations and poses and
        ``(K, M)`` reception."""
        if received.shape[0] != self.n_beliefs:
            raise ValueError(f"received must have {self.n_beliefs} rows, got {received.shape}")
        copies = np.array(z), np.array(poses), np.array(received, dtype=bool)
        self._entries.append(_Entry(sensor, *copies))

    def drop_latest(self, rows: NDArray[np.intp]) -> None:
        """Forget the last recorded observations of ``rows`` (their update was dropped)."""
        if self._entries:
            self._entries[-1].received[rows] = False

    def restart(self, rows: NDArray[np.intp]) -> None:
        """``rows`` start afresh from the prior (reset): they have no observations yet."""
        self._start[rows] = self._first + len(self._entries)
        drop = int(self._start.min()) - self._first
        if drop > 0:  # entries no row needs any more
            del self._entries[:drop]
            self._first += drop

    def observations(self, row: int) -> list[tuple[Any, FloatArray, FloatArray]]:
        """``(sensor, z, poses)`` of every observation belief ``row`` has kept, consecutive
        updates with the same sensor model concatenated (empty if none)."""
        begin = int(self._start[row]) - self._first
        groups: list[tuple[Any, list[FloatArray], list[FloatArray]]] = []
        for entry in self._entries[begin:]:
            group = row // (self.n_beliefs // entry.z.shape[0])
            mask = entry.received[row]
            if not mask.any():
                continue
            if not groups or groups[-1][0] is not entry.sensor:
                groups.append((entry.sensor, [], []))
            groups[-1][1].append(entry.z[group][mask])
            groups[-1][2].append(entry.poses[group][mask])
        return [(sensor, np.concatenate(z), np.concatenate(p)) for sensor, z, p in groups]

    def of_row(self, row: int) -> ObservationHistory:
        """A one-belief history holding belief ``row``'s observations."""
        single = ObservationHistory(1)
        for sensor, z, poses in self.observations(row):
            single.append(sensor, z[None], poses[None], np.ones((1, z.shape[0]), dtype=bool))
        return single
