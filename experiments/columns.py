"""A columnar read of a results store: only the fields the analysis reads.

``infoseek claims``, ``infoseek plot`` and the studies read every trial of a store but only a few
of its fields (:data:`ANALYSED_FIELDS`). :func:`read_trials` decodes only those columns of the
Parquet parts (every file still checked against its checksum, every page read against its
own) and turns each per-step series into a float64 array (``null`` -> NaN) without building a
Python float per value: on the 11124-trial Fig. 1 store that is several times faster than
reading whole rows (:func:`infoseek.experiments.store.read_rows`). The result is one
:class:`TrialView` per stored trial, in stored order (parts, then the journal; a key's first
occurrence), which the functions of :mod:`infoseek.experiments.analysis` take like
:class:`~infoseek.experiments.record.TrialRecord`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.experiments.store import read_columns

__all__ = ["ANALYSED_FIELDS", "TrialView", "read_trials"]

FloatArray = NDArray[np.float64]
#: The fields a :class:`TrialView` has.
ANALYSED_FIELDS: tuple[str, ...] = (
    "planner",
    "n_agents",
    "trial",
    "env_seed",
    "radius",
    "truth",
    "mass_agent0",
    "error_agent0",
    "plan_time",
)
_SERIES = ("mass_agent0", "error_agent0", "plan_time")
#: Fields that stores written before they were recorded lack (``None`` in a view).
_OPTIONAL = ("radius", "truth", "error_agent0")


@dataclass(frozen=True, slots=True, eq=False)
class TrialView:
    """The analysed fields of one stored trial (their meaning:
    :class:`~infoseek.experiments.record.TrialRecord`); series and ``truth`` are read-only
    float64 arrays (NaN where the store has ``null``); ``radius``, ``truth`` and
    ``error_agent0`` are ``None`` in stores written before they were recorded."""

    planner: str
    n_agents: int
    trial: int
    env_seed: int
    radius: float | None
    truth: FloatArray | None
    mass_agent0: FloatArray
    error_agent0: FloatArray | None
    plan_time: FloatArray


def read_trials(directory: str | os.PathLike[str]) -> list[TrialView]:
    """Every stored trial of the store in ``directory`` (module docstring).

    Raises:
        StoreConfigError: No results store in ``directory``.
        StoreCorruptError: Any file of the store is damaged (the message names it).
        ValueError: A trial without a field every store has (planner, fleet size, trial,
            seed, mass).
    """
    tables, journal = read_columns(directory, ANALYSED_FIELDS)
    views: list[TrialView] = []
    seen: set[str] = set()
    for table in tables:
        fresh = []
        for index, key in enumerate(table.column("key").to_pylist()):
            if key not in seen:
                seen.add(key)
                fresh.append(index)
        views.extend(_views_of_table(table, fresh))
    for row in journal:
        if row["key"] not in seen:
            seen.add(row["key"])
            views.append(_view_of_row(row))
    return views


def _views_of_table(table: Any, rows: Sequence[int]) -> list[TrialView]:
    """The views of rows ``rows`` of one part's table."""
    names = set(table.column_names)
    missing = [name for name in ANALYSED_FIELDS if name not in names and name not in _OPTIONAL]
    if missing:
        raise ValueError(f"the store's trials have no field(s) {missing}")
    columns: dict[str, Sequence[Any]] = {}
    for name in ("planner", "n_agents", "trial", "env_seed", "radius"):
        if name in names:
            columns[name] = table.column(name).to_pylist()
    for name in ("truth", *_SERIES):
        if name in names:
            columns[name] = _split(table.column(name))
    return [_view({name: values[i] for name, values in columns.items()}) for i in rows]


def _split(column: Any) -> list[FloatArray]:
    """A list column as one read-only float64 array per row (views of one flat array)."""
    import pyarrow.compute as pc

    array = column.combine_chunks()
    lengths = pc.fill_null(pc.list_value_length(array), 0).to_numpy(zero_copy_only=False)
    flat = pc.list_flatten(array).to_numpy(zero_copy_only=False).astype(np.float64)
    flat.flags.writeable = False
    return np.split(flat, np.cumsum(lengths)[:-1])


def _view_of_row(row: Mapping[str, Any]) -> TrialView:
    """The view of a journal row (JSON values, ``null`` for non-finite numbers)."""
    values: dict[str, Any] = {name: row[name] for name in ANALYSED_FIELDS if name in row}
    for name in ("truth", *_SERIES):
        if name in values:
            array = np.array([np.nan if v is None else v for v in values[name]], dtype=float)
            array.flags.writeable = False
            values[name] = array
    return _view(values)


def _view(values: Mapping[str, Any]) -> TrialView:
    radius = values.get("radius")
    return TrialView(
        planner=str(values["planner"]),
        n_agents=int(values["n_agents"]),
        trial=int(values["trial"]),
        env_seed=int(values["env_seed"]),
        radius=None if radius is None else float(radius),
        truth=values.get("truth"),
        mass_agent0=values["mass_agent0"],
        error_agent0=values.get("error_agent0"),
        plan_time=values["plan_time"],
    )
