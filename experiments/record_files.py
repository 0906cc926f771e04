"""JSON results files of studies whose trials are computed in one run and read whole by their
results page (the grid-posterior studies): the provenance, then one line per trial.

The layout is ``{"provenance": {...}, "trials": [row, row, ...]}`` with the provenance indented
and one trial record (a dataclass, written with :func:`dataclasses.asdict`) per line, keys
sorted, so that a diff of two runs reads trial by trial.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from infoseek.experiments.store import jsonable, read_manifest

__all__ = ["read_record_file", "rerun_provenance", "write_record_file"]


def write_record_file(
    path: str | os.PathLike[str], records: Sequence[Any], provenance: dict[str, Any]
) -> Path:
    """Write ``records`` (dataclass instances) and ``provenance`` to ``path``; returns it.

    Args:
        path: The file (its folder is created).
        records: One dataclass instance per trial.
        provenance: What produced them (command, inputs, machine, ...).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = json.dumps(jsonable(provenance), indent=1, sort_keys=True)
    lines = [json.dumps(jsonable(asdict(record)), sort_keys=True) for record in records]
    path.write_text(f'{{"provenance": {head},\n"trials": [\n' + ",\n".join(lines) + "\n]}\n")
    return path


def read_record_file(
    path: str | os.PathLike[str], what: str
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The trial rows and the provenance of the file at ``path``.

    Args:
        path: The file.
        what: What the file holds, for the error message (``"grid-posterior results"``).

    Raises:
        ValueError: No file there.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no {what} at {path}")
    body = json.loads(path.read_text())
    return list(body["trials"]), body["provenance"]


def rerun_provenance(
    command: str,
    store: str | os.PathLike[str],
    workers: int,
    wall_time: float,
    details: dict[str, Any],
) -> dict[str, Any]:
    """The provenance of a run that reran a store's trials: the command, the store and its run
    configuration, the study's ``details`` (its grid, groups, ...), the workers and wall time,
    the machine, the numerics and the time of writing.

    Args:
        command: The command line.
        store: The store whose trials were rerun.
        workers: Worker processes.
        wall_time: Seconds the run took.
        details: The study's own settings.
    """
    from infoseek.experiments.machine import describe_machine
    from infoseek.experiments.numerics import describe

    return {
        "command": command,
        "store": Path(os.path.relpath(store)).as_posix(),
        "config": read_manifest(store)["config"],
        **details,
        "workers": workers,
        "wall_time": round(wall_time, 1),
        "machine": describe_machine(),
        "numerics": describe(),
        "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
