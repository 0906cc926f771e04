"""``infoseek verify --integrity DIR``: check every file of a results store without rerunning.

What is checked (the format is in :mod:`infoseek.experiments.store`):

* the manifest: valid JSON in the exact form infoseek writes, its SHA-256 ``checksum``, the
  members a store needs;
* every part the manifest lists: present, of the recorded size and SHA-256, readable with every
  Parquet page checksum verified, with the recorded number of rows and a ``key`` column; a part
  file the manifest does not list is a problem too;
* the journal ``trials.jsonl``: every line canonical with a matching checksum (an incomplete
  last line, left by a writer stopped mid-write, is reported as a note: it is not data).

Stores of format versions 1 and 2 have no checksums: their parts are parsed (page checksums
are verified where a part has them) and the report says that the store is not sealed
(``infoseek migrate DIR`` seals it). Every problem is one line naming the file.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from infoseek.experiments import store
from infoseek.experiments.store import (
    CHECKSUMMED_VERSION,
    MANIFEST_NAME,
    PARTS_NAME,
    TRIALS_NAME,
    StoreError,
    StoreWarning,
)

__all__ = ["IntegrityReport", "check_integrity"]


@dataclass
class IntegrityReport:
    """Outcome of :func:`check_integrity`.

    Attributes:
        directory: The store checked.
        format_version: The manifest's format version (``None`` if the manifest is unusable).
        parts: Parts that passed every check.
        rows: Rows in those parts.
        journal_records: Complete records in the journal.
        problems: One line per damaged or unexpected file (empty: the store is intact).
        notes: Things that are not damage (an incomplete last journal line, leftover temporary
            files, a store without checksums).
    """

    directory: Path
    format_version: int | None = None
    parts: int = 0
    rows: int = 0
    journal_records: int = 0
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def sealed(self) -> bool:
        """Whether the store has checksums (format 3 or later)."""
        return self.format_version is not None and self.format_version >= CHECKSUMMED_VERSION

    def summary(self) -> str:
        """One line: what was checked and the verdict."""
        if self.format_version is None:
            return f"{self.directory}: manifest unusable, nothing else checked"
        verdict = "intact" if not self.problems else f"{len(self.problems)} problem(s)"
        return (
            f"{self.directory}: format {self.format_version}, {self.parts} part(s) with "
            f"{self.rows} trial(s) checked, journal {self.journal_records} record(s): {verdict}"
        )


def _check_parts(directory: Path, manifest: dict[str, Any], report: IntegrityReport) -> None:
    listed = manifest.get("parts")
    on_disk = {path.name: path for path in store._part_paths(directory)}
    names = sorted(listed) if listed is not None else sorted(on_disk)
    for name in names:
        path = directory / PARTS_NAME / name
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            report.problems.append(f"{path}: missing (the manifest lists it)")
            continue
        try:
            table = store.decode_part(path, data, None if listed is None else listed[name])
        except StoreError as error:
            report.problems.append(str(error))
            continue
        report.parts += 1
        report.rows += table.num_rows
    if listed is not None:
        for name in sorted(set(on_disk) - set(listed)):
            report.problems.append(
                f"{on_disk[name]}: a part the manifest does not list (left by a writer stopped "
                "while adding it, or copied in); rerun the bench command to repair, or remove it"
            )
    leftovers = sorted((directory / PARTS_NAME).glob(".part-*.tmp"))
    if leftovers:
        report.notes.append(
            f"{len(leftovers)} temporary file(s) of a stopped writer in {directory / PARTS_NAME}"
            " (not data; the next bench run removes them)"
        )


def _check_journal(directory: Path, manifest: dict[str, Any], report: IntegrityReport) -> None:
    path = directory / TRIALS_NAME
    checked = int(manifest["format_version"]) >= CHECKSUMMED_VERSION
    try:
        records, _, torn = store._scan(path, checked)
    except StoreError as error:
        report.problems.append(str(error))
        return
    report.journal_records = len(records)
    if torn:
        report.notes.append(
            f"{path}: an incomplete last line ({len(torn)} bytes) of a writer stopped "
            "mid-write (not data; the next bench run removes it)"
        )


def check_integrity(directory: str | os.PathLike[str]) -> IntegrityReport:
    """Check every file of the results store in ``directory`` (module docstring).

    Raises:
        StoreConfigError: ``directory`` is not a results store (no manifest).
    """
    directory = Path(directory)
    report = IntegrityReport(directory=directory)
    try:
        manifest = store.read_manifest(directory)
    except store.StoreCorruptError as error:
        report.problems.append(str(error))
        return report
    report.format_version = int(manifest["format_version"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StoreWarning)
        _check_parts(directory, manifest, report)
        _check_journal(directory, manifest, report)
    if not report.sealed:
        report.notes.append(
            f"{directory / MANIFEST_NAME}: format {report.format_version}, without checksums: "
            "damage inside a part's data can go unnoticed; `infoseek migrate` records them"
        )
    return report
