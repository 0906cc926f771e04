"""JSON results files of studies whose trials are computed in one run and read whole by their
results page (the grid-posterior studies): the provenance, then one line per trial.

The layout is ``{"provenance": {...}, "trials": [row, row, ...]}`` with the provenance indented
and one trial record (a dataclass, written with :func:`dataclasses.asdict`) per line, keys
sorted, so that a diff of two runs reads trial by trial.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from infoseek.experiments.store import jsonable

__all__ = ["read_record_file", "write_record_file"]


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
