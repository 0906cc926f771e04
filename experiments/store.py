"""Append-only results store of the Monte Carlo benchmark (``infoseek bench``).

A store is a directory holding:

``manifest.json``
    One sealed JSON object (:mod:`infoseek.experiments.checksums`: canonical form and a
    SHA-256 ``checksum`` over everything else, so any change made outside infoseek is found),
    replaced atomically (temporary file, ``fsync``, rename) when the store is created and each
    time a part is added. Its ``config`` member is the configuration that defines the run and
    that every trial in the store shares; ``parts`` lists every part with its checksum::

        {
          "checksum": "sha256:...",                     # of the canonical JSON of the rest
          "format": "infoseek-bench-store",
          "format_version": 3,
          "created": "2006-12-13T12:00:00+00:00",      # informational, never compared
          "numerics": {...},                            # the numerical environment that wrote
                                                        # it (informational; see
                                                        # infoseek.experiments.numerics)
          "config": {
            "env": "bearings_v0",                       # environment id (or "module:callable")
            "env_kwargs": {"n_particles": 2000},        # keyword arguments of every env, minus
                                                        # n_agents and max_cycles (set per trial)
            "steps": 30,                                # episode length of every trial
            "seed": 0,                                  # the run's root seed
            "version": "0.1.0"                          # infoseek version that wrote the store
          },
          "parts": {"part-00001.parquet": {"bytes": 52311, "rows": 200, "sha256": "sha256:..."}},
          "runs": [{"trials": 200, "wall_time": 812.4, "backend": "process", "workers": 2,
                    "machine": {...}, "version": "0.1.0", "finished": "..."}]
        }                                               # runs: informational, one per run that
                                                        # stored trials (stores written before
                                                        # infoseek recorded them have none)

    Opening an existing store with a different ``config`` fails (:class:`StoreConfigError`,
    naming every differing field) before anything is written, so a directory written by
    another configuration is never modified. Planners and agent counts are *not* part of the
    configuration: they are part of each trial's key, so new planners or agent counts can be
    added to an existing run.

``parts/part-NNNNN.parquet``
    The stored trials, compact: Apache Parquet (zstd) tables, one row per trial, written once
    and never modified, with Parquet page checksums (verified on every read) and the SHA-256 of
    the whole file in the manifest. Per-step series are stored in single precision
    (``float32``, about 7 significant digits: far below any difference a claim or figure
    resolves; ``infoseek verify`` compares within a stated tolerance), identifiers, seeds and
    the true target in full precision.

``trials.jsonl``
    The journal of a run in progress: JSON Lines, one object per finished trial, appended in
    completion order, each line carrying the checksum of its content
    (:func:`~infoseek.experiments.checksums.encode_checked_line`). Each line is written with a
    single ``write`` followed by ``flush`` and ``os.fsync``, so a finished trial survives a
    crash. A record carries at least ``key`` (a string, unique in the store,
    ``"<planner>/agents=<n>/trial=<k>"``), ``planner``, ``n_agents`` and ``trial``; the
    benchmark adds the per-step metrics (see :mod:`infoseek.experiments.bench`). Non-finite
    floats are stored as ``null`` (strict JSON). When the writer closes (normally, on an
    exception or on Ctrl-C) or a writer opens a store with a non-empty journal, the journal's
    trials are written to a new part (temporary file, ``fsync``, rename), the part is recorded
    in the manifest, and then the journal is emptied; a crash in between leaves trials in
    both places, which readers count once (a key's first occurrence wins, parts before the
    journal), or a part the manifest does not list yet, which the next writer removes (its
    trials are still in the journal) and readers refuse.

    A process killed in the middle of a ``write`` leaves a *torn* last line (no trailing
    newline). Readers ignore it with a :class:`StoreWarning`; a writer opening the store
    truncates the file back to the end of the last complete line before appending. Any other
    damage (a line that is not valid, not canonical or fails its checksum, wherever it is)
    means the file was changed by something else: reading fails with
    :class:`StoreCorruptError` rather than silently dropping or misreading data.

Every damage to a part, the manifest or a journal line is an error naming the file and what is
wrong, never a number (``infoseek verify --integrity DIR`` checks a whole store; the one
silent case is a journal cut at a line boundary, which reads as a run stopped earlier).

A writer holds an exclusive ``fcntl`` lock on ``trials.jsonl`` while the store is open, so two
runs cannot append to the same directory at once (the second fails with a clear message).
Stores of format versions 1 (journal only) and 2 (parts without checksums) are read as they
are; a writer opening a version 2 store records its parts' checksums (version 3) first.
"""

from __future__ import annotations

import datetime
import errno
import json
import math
import os
import warnings
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from infoseek.experiments.checksums import (
    ChecksumError,
    decode_checked_line,
    decode_sealed,
    digest,
    encode_checked_line,
    encode_sealed,
)
from infoseek.experiments.record import TrialRecord, trial_key

FORMAT = "infoseek-bench-store"
FORMAT_VERSION = 3
#: Format versions this infoseek reads.
READABLE_VERSIONS = (1, 2, 3)
#: First format version with checksums (sealed manifest, listed parts, checked journal lines).
CHECKSUMMED_VERSION = 3
MANIFEST_NAME = "manifest.json"
TRIALS_NAME = "trials.jsonl"
PARTS_NAME = "parts"
#: List-valued record fields kept in double precision (all other float lists: float32).
FULL_PRECISION_FIELDS = frozenset({"truth"})
#: Columns every part must have.
REQUIRED_COLUMNS = ("key",)


class StoreError(ValueError):
    """Base class of results-store errors (a ``ValueError``: bad input from the user)."""


class StoreConfigError(StoreError):
    """The directory holds results of another configuration (or is not a results store)."""


class StoreCorruptError(StoreError):
    """A file of the store is damaged or was changed outside infoseek (the message names it)."""


class StoreLockedError(StoreError):
    """Another process is writing to the same store."""


class StoreWarning(UserWarning):
    """Something a reader skipped that is not damage (a torn last journal line)."""


def jsonable(value: Any) -> Any:
    """``value`` with non-finite floats replaced by ``None`` and numpy scalars made plain."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):  # numpy arrays/scalars
        return jsonable(value.tolist())
    return value


def encode_record(record: Mapping[str, Any]) -> str:
    """One JSON line (with trailing newline) for ``record``; keys sorted, strict JSON."""
    return json.dumps(jsonable(record), sort_keys=True, allow_nan=False) + "\n"


def encode_journal_line(record: Mapping[str, Any]) -> bytes:
    """The journal line of ``record`` (strict JSON, keys sorted, with its checksum)."""
    return encode_checked_line(jsonable(dict(record)))


def _decode_line(line: bytes, checked: bool) -> dict[str, Any]:
    """The record of one complete journal line (``ValueError`` if it is not one)."""
    if checked:
        record = decode_checked_line(line)
    else:  # format 1/2 journals: plain JSON lines
        record = json.loads(line)
        if not isinstance(record, dict):
            raise ValueError("not a JSON object")
    if not isinstance(record.get("key"), str):
        raise ValueError("not a record with a string 'key'")
    return record


def _scan(path: Path, checked: bool = True) -> tuple[list[dict[str, Any]], int, bytes]:
    """Parse ``trials.jsonl``.

    Args:
        path: The journal.
        checked: Lines carry checksums (format 3); else plain JSON lines.

    Returns:
        The complete records (first occurrence of each key, in file order), the byte offset
        just past the last complete record (where a writer must truncate to) and the torn
        tail after it (``b""`` if none). A last line without its newline that is a whole
        valid record (only the newline lost) counts as complete.

    Raises:
        StoreCorruptError: A line with its newline is not a valid record.
    """
    if not path.exists():
        return [], 0, b""
    data = path.read_bytes()
    records: list[dict[str, Any]] = []
    seen: set[str] = set()
    offset = 0
    while offset < len(data):
        newline = data.find(b"\n", offset)
        if newline == -1:  # no newline: a torn write, unless the record is whole
            try:
                record = _decode_line(data[offset:] + b"\n", checked)
            except ValueError:
                return records, offset, data[offset:]
            if record["key"] not in seen:
                records.append(record)
            return records, len(data), b""
        line = data[offset : newline + 1]
        if line.strip() or checked:
            try:
                record = _decode_line(line, checked)
            except ValueError as error:
                lineno = data.count(b"\n", 0, offset) + 1
                raise StoreCorruptError(
                    f"{path}: line {lineno} is not a valid trial record ({error}); "
                    "the file was modified outside infoseek - repair or remove that line"
                ) from None
            if record["key"] not in seen:
                seen.add(record["key"])
                records.append(record)
        offset = newline + 1
    return records, offset, b""


def _warn_torn(path: Path, torn: bytes) -> None:
    if torn:
        warnings.warn(
            f"{path}: ignored an incomplete last line ({len(torn)} bytes: a writer stopped in "
            "the middle of a write, or one still writing); the next bench run removes it",
            StoreWarning,
            stacklevel=3,
        )


def _manifest_version(manifest: Mapping[str, Any], path: Path) -> int:
    if manifest.get("format") != FORMAT:
        raise StoreConfigError(f"{path}: not an infoseek results manifest")
    version = manifest.get("format_version")
    if version not in READABLE_VERSIONS:
        raise StoreConfigError(
            f"{path}: store format version {version!r}, this infoseek reads versions "
            f"{list(READABLE_VERSIONS)}"
        )
    return int(version)


def read_manifest(directory: str | os.PathLike[str]) -> dict[str, Any]:
    """The manifest of the store in ``directory`` (without its ``checksum`` member).

    Raises:
        StoreConfigError: No store there (no manifest), or not an infoseek manifest.
        StoreCorruptError: The manifest is damaged (invalid JSON, changed bytes, bad checksum,
            missing members).
    """
    if Path(directory).exists() and not Path(directory).is_dir():
        raise StoreConfigError(f"{directory}: is a file, expected a results directory")
    path = Path(directory) / MANIFEST_NAME
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        inner = Path(directory) / "store"
        hint = (
            f"; the results store of a study run is {inner}"
            if (inner / MANIFEST_NAME).is_file()
            else ""
        )
        raise StoreConfigError(
            f"{directory}: not an infoseek results directory (no {MANIFEST_NAME}){hint}"
        ) from None
    try:
        manifest = json.loads(data)
    except ValueError as error:
        raise StoreCorruptError(f"{path}: damaged manifest, not valid JSON ({error})") from None
    if not isinstance(manifest, dict):
        raise StoreCorruptError(f"{path}: damaged manifest, not a JSON object")
    if manifest.get("format_version") == CHECKSUMMED_VERSION or "checksum" in manifest:
        try:
            manifest = decode_sealed(data)
        except ChecksumError as error:
            raise StoreCorruptError(f"{path}: damaged manifest, {error}") from None
    version = _manifest_version(manifest, path)
    if not isinstance(manifest.get("config"), dict):
        raise StoreCorruptError(f"{path}: damaged manifest, no 'config' object")
    if version >= CHECKSUMMED_VERSION and not isinstance(manifest.get("parts"), dict):
        raise StoreCorruptError(f"{path}: damaged manifest, no 'parts' object")
    return manifest


def _now() -> str:
    """The time now, UTC, ISO 8601 to the second."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def _write_manifest(directory: Path, manifest: Mapping[str, Any]) -> None:
    """Replace the manifest durably (temporary file, fsync, rename, fsync of the folder)."""
    path = directory / MANIFEST_NAME
    tmp = path.with_suffix(".json.tmp")
    with open(tmp, "wb") as handle:
        handle.write(encode_sealed(manifest))
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)
    _fsync_directory(directory)


def _fsync_directory(directory: Path) -> None:
    directory_fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(directory_fd)
    finally:
        os.close(directory_fd)


def _part_paths(directory: Path) -> list[Path]:
    parts = directory / PARTS_NAME
    return sorted(parts.glob("part-*.parquet")) if parts.is_dir() else []


def part_info(data: bytes, rows: int) -> dict[str, Any]:
    """The manifest entry of a part with content ``data`` and ``rows`` rows."""
    return {"bytes": len(data), "rows": int(rows), "sha256": digest(data)}


def decode_part(
    path: Path,
    data: bytes,
    listed: Mapping[str, Any] | None,
    columns: Sequence[str] | None = None,
) -> Any:
    """The ``pyarrow.Table`` of the part ``path`` with content ``data``, checked.

    Args:
        path: Where the part was read from (for messages).
        data: Its bytes.
        listed: Its manifest entry (:func:`part_info`), or ``None`` (an older store: no
            whole-file checksum).
        columns: Decode only these columns (those the part has) and ``key``; ``None``: all.
            The whole file's checksum is checked either way, and the pages read are.

    Raises:
        StoreCorruptError: Size or checksum differ from the manifest's, a Parquet page fails
            its checksum, the file does not parse, rows differ from the manifest's, or a
            required column is missing.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    if listed is not None:
        if len(data) != listed.get("bytes"):
            raise StoreCorruptError(
                f"{path}: damaged part, {len(data)} bytes where the manifest records "
                f"{listed.get('bytes')} (truncated or overwritten)"
            )
        if digest(data) != listed.get("sha256"):
            raise StoreCorruptError(
                f"{path}: damaged part, its SHA-256 differs from the manifest's "
                "(modified or damaged)"
            )
    # Arrow-owned memory: a buffer over the Python bytes could be released by one of
    # pyarrow's threads during interpreter shutdown, which needs the GIL and aborts.
    buffer = pa.allocate_buffer(len(data))
    pa.FixedSizeBufferWriter(buffer).write(data)
    try:
        source = pa.BufferReader(buffer)
        if columns is not None:
            present = pq.read_schema(pa.BufferReader(buffer)).names
            columns = [name for name in present if name in {*columns, *REQUIRED_COLUMNS}]
        table = pq.read_table(source, columns=columns, page_checksum_verification=True)
    except Exception as error:  # pyarrow raises several types for damaged files
        raise StoreCorruptError(f"{path}: damaged part, unreadable ({error})") from None
    if listed is not None and table.num_rows != listed.get("rows"):
        raise StoreCorruptError(
            f"{path}: damaged part, {table.num_rows} rows where the manifest records "
            f"{listed.get('rows')}"
        )
    missing = [name for name in REQUIRED_COLUMNS if name not in table.column_names]
    if missing:
        raise StoreCorruptError(f"{path}: damaged part, no column(s) {missing}")
    return table


def _read_tables(
    directory: Path, manifest: Mapping[str, Any], columns: Sequence[str] | None = None
) -> list[Any]:
    """Every part's checked table, in part order (only ``columns`` and ``key``, if given).

    Raises:
        StoreCorruptError: A damaged part, a part the manifest lists that is missing, or (a
            checksummed store) a part it does not list.
    """
    listed: Mapping[str, Any] | None = manifest.get("parts")
    paths = _part_paths(directory)
    if listed is not None:
        unlisted = [path for path in paths if path.name not in listed]
        if unlisted:
            raise StoreCorruptError(
                f"{unlisted[0]}: a part the manifest does not list (left by a writer stopped "
                "while adding it, or copied in from elsewhere); rerun the bench command to "
                "repair the store, or remove the file"
            )
        paths = [directory / PARTS_NAME / name for name in sorted(listed)]
    tables = []
    for path in paths:
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            raise StoreCorruptError(f"{path}: missing (the manifest lists it)") from None
        entry = None if listed is None else listed[path.name]
        tables.append(decode_part(path, data, entry, columns))
    return tables


def _read_parts(directory: Path, manifest: Mapping[str, Any]) -> list[dict[str, Any]]:
    return [record for table in _read_tables(directory, manifest) for record in table.to_pylist()]


def _merge(*sources: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Records of every source, the first occurrence of each key kept."""
    merged: list[dict[str, Any]] = []
    seen: set[str] = set()
    for records in sources:
        for record in records:
            if record["key"] not in seen:
                seen.add(record["key"])
                merged.append(record)
    return merged


def _journal_checked(manifest: Mapping[str, Any]) -> bool:
    return int(manifest["format_version"]) >= CHECKSUMMED_VERSION


def read_rows(directory: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every complete trial row of the store in ``directory``: the parts, then the journal (a
    torn last line ignored with a :class:`StoreWarning`), each key once.

    Raises:
        StoreConfigError: No results store in ``directory``.
        StoreCorruptError: Any file of the store is damaged (the message names it).
    """
    tables, journal = read_columns(directory)
    return _merge([row for table in tables for row in table.to_pylist()], journal)


def read_records(directory: str | os.PathLike[str]) -> list[TrialRecord]:
    """Every complete trial of the store in ``directory`` as a
    :class:`~infoseek.experiments.record.TrialRecord` (:func:`read_rows`, typed; series in
    stored precision).

    Raises:
        StoreConfigError: No results store in ``directory``.
        StoreCorruptError: Any file of the store is damaged (the message names it).
        ValueError: A stored trial lacks a field of the record's schema.
    """
    return [TrialRecord.from_row(row) for row in read_rows(directory)]


def read_columns(
    directory: str | os.PathLike[str], columns: Sequence[str] | None = None
) -> tuple[list[Any], list[dict[str, Any]]]:
    """The stored trials of ``directory`` as read, before duplicates are dropped: every part's
    checked ``pyarrow.Table`` (only ``columns`` and ``key``, if given; a part without some of
    them has fewer) in part order, and the journal's rows (a torn last line ignored with a
    :class:`StoreWarning`). A key's first occurrence, parts before the journal, is the stored
    trial (:func:`read_rows` keeps only those).

    Raises:
        StoreConfigError: No results store in ``directory``.
        StoreCorruptError: Any file of the store is damaged (the message names it).
    """
    manifest = read_manifest(directory)
    journal_path = Path(directory) / TRIALS_NAME
    journal, _, torn = _scan(journal_path, _journal_checked(manifest))
    _warn_torn(journal_path, torn)
    return _read_tables(Path(directory), manifest, columns), journal


def encode_part(records: list[dict[str, Any]]) -> Any:
    """A ``pyarrow.Table`` of ``records``: float lists in float32 except
    :data:`FULL_PRECISION_FIELDS`; a list column with only nulls (``min_separation`` of
    one-vehicle trials) as float32 too.

    The table is built in the stored schema directly (no cast: pyarrow cannot cast a list of
    nulls), which rounds each double to float32 as a cast does.
    """
    import pyarrow as pa

    rows = [jsonable(dict(record)) for record in records]
    fields = []
    for field in pa.Table.from_pylist(rows).schema:
        kind = field.type
        if pa.types.is_list(kind) and (
            pa.types.is_null(kind.value_type)
            or (pa.types.is_floating(kind.value_type) and field.name not in FULL_PRECISION_FIELDS)
        ):
            kind = pa.list_(pa.float32())
        fields.append(pa.field(field.name, kind))
    return pa.Table.from_pylist(rows, schema=pa.schema(fields))


def as_stored(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``records`` as a part stores them (float32 series): what :func:`read_rows` returns
    for them after compaction."""
    return encode_part(records).to_pylist() if records else []


def part_keys(directory: str | os.PathLike[str]) -> list[str]:
    """The key of every row of every part, in order, duplicates included (for checks)."""
    manifest = read_manifest(directory)
    return [
        key
        for table in _read_tables(Path(directory), manifest)
        for key in table.column("key").to_pylist()
    ]


def _write_part(directory: Path, table: Any) -> tuple[Path, dict[str, Any]]:
    """Write ``table`` as the next part, durably (temporary file, fsync, rename); returns
    its path and manifest entry (the caller records it in the manifest)."""
    import pyarrow.parquet as pq

    parts = directory / PARTS_NAME
    parts.mkdir(exist_ok=True)
    existing = _part_paths(directory)
    number = 1 + max((int(p.stem.split("-")[1]) for p in existing), default=0)
    path = parts / f"part-{number:05d}.parquet"
    tmp = parts / f".{path.name}.tmp"
    pq.write_table(table, tmp, compression="zstd", write_page_checksum=True)
    with open(tmp, "rb") as handle:
        data = handle.read()
        os.fsync(handle.fileno())
    os.replace(tmp, path)
    _fsync_directory(parts)
    return path, part_info(data, table.num_rows)


def _config_differences(stored: Mapping[str, Any], wanted: Mapping[str, Any]) -> list[str]:
    names = sorted(set(stored) | set(wanted))
    return [
        f"{name}: stored {stored.get(name)!r}, requested {wanted.get(name)!r}"
        for name in names
        if jsonable(stored.get(name)) != jsonable(wanted.get(name))
    ]


class ResultsStore:
    """Writer of one results directory (see the module docstring for the format).

    Use as a context manager, or call :meth:`close`. Opening validates (or creates) the
    manifest, takes the writer lock, truncates a torn last line, records the checksums of an
    older store's parts (format 3), removes a part a stopped writer did not record (its trials
    are still in the journal) and loads the keys of the trials already stored.

    Args:
        directory: The results directory (created if missing).
        config: The run configuration (JSON-serialisable mapping). A new store records it; an
            existing store must have exactly this configuration.

    Raises:
        StoreConfigError: ``directory`` holds another configuration, or is a non-empty
            directory that is not a results store.
        StoreLockedError: Another process is writing to this store.
        StoreCorruptError: A file of the store is damaged.
    """

    def __init__(self, directory: str | os.PathLike[str], config: Mapping[str, Any]) -> None:
        self.directory = Path(directory)
        self.config: dict[str, Any] = jsonable(dict(config))
        manifest_path = self.directory / MANIFEST_NAME
        if self.directory.exists() and not self.directory.is_dir():
            raise StoreConfigError(f"{self.directory}: exists and is not a directory")
        if manifest_path.exists():
            self._manifest = read_manifest(self.directory)
            differences = _config_differences(self._manifest["config"], self.config)
            if differences:
                raise StoreConfigError(
                    f"{self.directory} holds results of another configuration; nothing was "
                    "changed. Use another --out directory, or the stored settings. "
                    "Differences: " + "; ".join(differences)
                )
        else:
            if self.directory.exists() and any(self.directory.iterdir()):
                raise StoreConfigError(
                    f"{self.directory}: not empty and not an infoseek results directory "
                    f"(no {MANIFEST_NAME}); refusing to write into it"
                )
            self.directory.mkdir(parents=True, exist_ok=True)
            from infoseek.experiments.numerics import describe

            self._manifest = {
                "format": FORMAT,
                "format_version": FORMAT_VERSION,
                "created": _now(),
                "config": self.config,
                "numerics": describe(),
                "parts": {},
            }
            _write_manifest(self.directory, self._manifest)
        self._file = open(self.directory / TRIALS_NAME, "a+b")  # noqa: SIM115 - see close()
        try:
            self._lock()
            records = self._recover()
            stored = {
                key
                for table in _read_tables(self.directory, self._manifest)
                for key in table.column("key").to_pylist()
            }
        except BaseException:
            self._file.close()
            raise
        self._keys: set[str] = stored | {record["key"] for record in records}
        self._stored = stored  # keys already in parts
        if records:  # a journal left by a killed writer: keep its trials in a part
            self._compact()

    def _recover(self) -> list[dict[str, Any]]:
        """Bring a store left by an older format or a stopped writer into a clean state
        (under the lock); returns the journal's records."""
        trials_path = self.directory / TRIALS_NAME
        checked = _journal_checked(self._manifest)
        records, good_end, _ = _scan(trials_path, checked)
        if self._file.seek(0, os.SEEK_END) != good_end:  # torn tail of a killed writer
            self._file.truncate(good_end)
            self._sync()
        if good_end:
            self._file.seek(good_end - 1)
            if self._file.read(1) != b"\n":  # a whole last record that lost its newline
                self._file.write(b"\n")
                self._sync()
        if not checked:
            self._seal_older_store(records)
            records = []
        listed = self._manifest["parts"]
        journal_keys = {record["key"] for record in records}
        for path in _part_paths(self.directory):
            if path.name not in listed:
                keys = decode_part(path, path.read_bytes(), None).column("key").to_pylist()
                if not set(keys) <= journal_keys:
                    raise StoreCorruptError(
                        f"{path}: a part the manifest does not list, with trials that are not "
                        "in the journal (copied in from elsewhere?); remove or move it"
                    )
                path.unlink()  # its trials are compacted again from the journal
        for leftover in (self.directory / PARTS_NAME).glob(".part-*.tmp"):
            leftover.unlink()
        return records

    def _seal_older_store(self, records: list[dict[str, Any]]) -> None:
        """Make a format 1/2 store format 3: its journal compacted the old way (a part, then
        the journal emptied: a crash in between leaves a valid older store), then the
        checksums of every part (each read and checked first) recorded in the manifest."""
        if records:
            stored = {
                key
                for table in _read_tables(self.directory, self._manifest)
                for key in table.column("key").to_pylist()
            }
            fresh = [record for record in records if record["key"] not in stored]
            if fresh:
                _write_part(self.directory, encode_part(fresh))
            self._file.truncate(0)
            self._sync()
        listed = {}
        for path in _part_paths(self.directory):
            data = path.read_bytes()
            listed[path.name] = part_info(data, decode_part(path, data, None).num_rows)
        self._manifest = {**self._manifest, "format_version": FORMAT_VERSION, "parts": listed}
        _write_manifest(self.directory, self._manifest)

    def _sync(self) -> None:
        self._file.flush()
        os.fsync(self._file.fileno())

    def _lock(self) -> None:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - non-POSIX: no lock
            return
        try:
            fcntl.flock(self._file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            if error.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise StoreLockedError(
                    f"{self.directory}: another infoseek process is writing to this store"
                ) from None
            raise

    @property
    def keys(self) -> frozenset[str]:
        """Keys of the trials stored so far."""
        return frozenset(self._keys)

    def __contains__(self, key: object) -> bool:
        return key in self._keys

    def __len__(self) -> int:
        return len(self._keys)

    def append(self, record: Mapping[str, Any]) -> bool:
        """Append one finished trial durably (write, flush, fsync).

        Args:
            record: The trial record; must have a string ``key``.

        Returns:
            ``True`` if written, ``False`` if a trial with that key was already stored (the
            record is then dropped, so a trial is never stored twice).
        """
        key = record.get("key")
        if not isinstance(key, str):
            raise TypeError(f"record: expected a string 'key', got {key!r}")
        if key in self._keys:
            return False
        self._file.write(encode_journal_line(record))
        self._sync()
        self._keys.add(key)
        return True

    def records(self) -> list[dict[str, Any]]:
        """Every stored record (parts, then the journal; first occurrence per key)."""
        journal, _, _ = _scan(self.directory / TRIALS_NAME)
        return _merge(_read_parts(self.directory, self._manifest), journal)

    def record_run(self, run: Mapping[str, Any]) -> None:
        """Add one entry to the manifest's ``runs`` (informational, like ``numerics``: when a
        run stored trials, how many, its wall time, backend and machine), written durably."""
        runs = [*self._manifest.get("runs", []), {**jsonable(dict(run)), "finished": _now()}]
        self._manifest = {**self._manifest, "runs": runs}
        _write_manifest(self.directory, self._manifest)

    def _add_part(self, table: Any) -> None:
        """Write ``table`` as a new part and record it in the manifest."""
        path, info = _write_part(self.directory, table)
        parts = {**self._manifest["parts"], path.name: info}
        self._manifest = {**self._manifest, "parts": parts}
        _write_manifest(self.directory, self._manifest)

    def _compact(self) -> None:
        """Move the journal's trials into a new part, then empty the journal."""
        journal, _, _ = _scan(self.directory / TRIALS_NAME)
        fresh = [record for record in journal if record["key"] not in self._stored]
        if fresh:
            self._add_part(encode_part(fresh))
            self._stored.update(record["key"] for record in fresh)
        if journal:
            self._file.truncate(0)
            self._sync()

    def relabel(self, planners: Mapping[str, str]) -> int:
        """Rename planner labels in every part (keys follow), keeping every other value.

        The parts are rewritten column by column (the other columns' values and types are
        copied as they are) into new parts, recorded in the manifest, and the old parts are
        removed. Used by ``infoseek migrate`` (portable policy labels).

        Args:
            planners: Old planner label -> new label. A new label must not already be a group
                of the store.

        Returns:
            The number of rows relabelled.
        """
        import pyarrow as pa

        self._compact()
        tables = _read_tables(self.directory, self._manifest)
        labels = {label for t in tables for label in t.column("planner").to_pylist()}
        clashes = sorted(set(planners.values()) & (labels - set(planners)))
        if clashes:
            raise StoreConfigError(f"{self.directory}: groups {clashes} are already stored")
        old_parts = sorted(self._manifest["parts"])
        if not any(label in planners for label in labels):
            return 0
        changed = 0
        self._manifest = {**self._manifest, "parts": {}}
        for table in tables:
            old = table.column("planner").to_pylist()
            new = [planners.get(label, label) for label in old]
            changed += sum(a != b for a, b in zip(old, new, strict=True))
            keys = [
                trial_key(label, n, k)
                for label, n, k in zip(
                    new,
                    table.column("n_agents").to_pylist(),
                    table.column("trial").to_pylist(),
                    strict=True,
                )
            ]
            for name, values in (("planner", new), ("key", keys)):
                index = table.column_names.index(name)
                column = pa.array(values, type=table.schema.field(name).type)
                table = table.set_column(index, table.schema.field(name), column)
            self._add_part(table)
        for name in old_parts:
            (self.directory / PARTS_NAME / name).unlink()
        self._stored = {
            key
            for table in _read_tables(self.directory, self._manifest)
            for key in table.column("key").to_pylist()
        }
        self._keys = set(self._stored)
        return changed

    def close(self) -> None:
        """Compact the journal into a part, release the lock and close (idempotent)."""
        if not self._file.closed:
            try:
                self._compact()
            finally:
                self._file.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._keys))
