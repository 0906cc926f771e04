"""Append-only results store of the Monte Carlo benchmark (``infoseek bench``).

A store is a directory holding:

``manifest.json``
    One JSON object, written once (atomically: temporary file + rename) when the store is
    created. Its ``config`` member is the configuration that defines the run and that every
    trial in the store shares::

        {
          "format": "infoseek-bench-store",
          "format_version": 2,
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
          }
        }

    Opening an existing store with a different ``config`` fails (:class:`StoreConfigError`,
    naming every differing field) before anything is written, so a directory written by
    another configuration is never modified. Planners and agent counts are *not* part of the
    configuration: they are part of each trial's key, so new planners or agent counts can be
    added to an existing run.

``parts/part-NNNNN.parquet``
    The stored trials, compact: Apache Parquet (zstd) tables, one row per trial, written once
    and never modified. Per-step series are stored in single precision (``float32``, about 7
    significant digits: far below any difference a claim or figure resolves; ``infoseek
    verify`` compares within a stated tolerance), identifiers, seeds and the true target in
    full precision.

``trials.jsonl``
    The journal of a run in progress: JSON Lines, one object per finished trial, appended in
    completion order. Each line is written with a single ``write`` followed by ``flush`` and
    ``os.fsync``, so a finished trial survives a crash. A record carries at least ``key`` (a
    string, unique in the store, ``"<planner>/agents=<n>/trial=<k>"``), ``planner``,
    ``n_agents`` and ``trial``; the benchmark adds the per-step metrics (see
    :mod:`infoseek.experiments.bench`). Non-finite floats are stored as ``null`` (strict
    JSON). When the writer closes (normally, on an exception or on Ctrl-C) or a writer opens a
    store with a non-empty journal, the journal's trials are written to a new part (temporary
    file, ``fsync``, rename) and then the journal is emptied; a crash between the two leaves
    trials in both places, which readers count once (a key's first occurrence wins, parts
    before the journal).

    A process killed in the middle of a ``write`` leaves a *torn* last line (no trailing
    newline, or not valid JSON). Readers ignore it; a writer opening the store truncates the
    file back to the end of the last complete line before appending. A malformed line that is
    *not* the last one means the file was damaged by something else: reading fails with
    :class:`StoreCorruptError` rather than silently dropping data.

A writer holds an exclusive ``fcntl`` lock on ``trials.jsonl`` while the store is open, so two
runs cannot append to the same directory at once (the second fails with a clear message).
Stores of format version 1 (journal only) are read as they are.
"""

from __future__ import annotations

import datetime
import errno
import json
import math
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

FORMAT = "infoseek-bench-store"
FORMAT_VERSION = 2
#: Format versions this infoseek reads.
READABLE_VERSIONS = (1, 2)
MANIFEST_NAME = "manifest.json"
TRIALS_NAME = "trials.jsonl"
PARTS_NAME = "parts"
#: List-valued record fields kept in double precision (all other float lists: float32).
FULL_PRECISION_FIELDS = frozenset({"truth"})


class StoreError(ValueError):
    """Base class of results-store errors (a ``ValueError``: bad input from the user)."""


class StoreConfigError(StoreError):
    """The directory holds results of another configuration (or is not a results store)."""


class StoreCorruptError(StoreError):
    """A line other than the last one of ``trials.jsonl`` is not a valid record."""


class StoreLockedError(StoreError):
    """Another process is writing to the same store."""


def trial_key(planner: str, n_agents: int, trial: int) -> str:
    """The unique key of one trial in a store.

    Args:
        planner: Planner label (a scripted planner name, or ``"policy:<path>"``).
        n_agents: Number of vehicles.
        trial: Trial index within the (planner, n_agents) group.

    Returns:
        ``"<planner>/agents=<n_agents>/trial=<trial>"``.
    """
    return f"{planner}/agents={int(n_agents)}/trial={int(trial)}"


def _jsonable(value: Any) -> Any:
    """``value`` with non-finite floats replaced by ``None`` and numpy scalars made plain."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):  # numpy arrays/scalars
        return _jsonable(value.tolist())
    return value


def encode_record(record: Mapping[str, Any]) -> str:
    """One JSON line (with trailing newline) for ``record``; keys sorted, strict JSON."""
    return json.dumps(_jsonable(record), sort_keys=True, allow_nan=False) + "\n"


def _scan(path: Path) -> tuple[list[dict[str, Any]], int]:
    """Parse ``trials.jsonl``.

    Returns:
        The complete records (first occurrence of each key, in file order) and the byte
        offset just past the last complete line (where a writer must truncate to).

    Raises:
        StoreCorruptError: A line other than the last is not a JSON object with a ``key``.
    """
    if not path.exists():
        return [], 0
    data = path.read_bytes()
    records: list[dict[str, Any]] = []
    seen: set[str] = set()
    offset = 0
    good_end = 0
    while offset < len(data):
        newline = data.find(b"\n", offset)
        is_last = newline == -1 or newline == len(data) - 1
        end = len(data) if newline == -1 else newline + 1
        line = data[offset:end]
        try:
            if newline == -1:
                raise ValueError("no trailing newline")
            record = json.loads(line)
            if not isinstance(record, dict) or not isinstance(record.get("key"), str):
                raise ValueError("not a record with a string 'key'")
        except ValueError as error:
            if is_last:  # torn write of a killed process: ignore
                break
            if not line.strip():  # stray blank line: harmless
                offset = end
                good_end = end
                continue
            lineno = data.count(b"\n", 0, offset) + 1
            raise StoreCorruptError(
                f"{path}: line {lineno} is not a valid trial record ({error}); "
                "the file was modified outside infoseek - repair or remove that line"
            ) from None
        if record["key"] not in seen:
            seen.add(record["key"])
            records.append(record)
        offset = end
        good_end = end
    return records, good_end


def read_manifest(directory: str | os.PathLike[str]) -> dict[str, Any]:
    """The manifest of the store in ``directory``.

    Raises:
        StoreConfigError: No store there (no readable manifest).
    """
    if Path(directory).exists() and not Path(directory).is_dir():
        raise StoreConfigError(f"{directory}: is a file, expected a results directory")
    path = Path(directory) / MANIFEST_NAME
    try:
        manifest = json.loads(path.read_text())
    except FileNotFoundError:
        raise StoreConfigError(
            f"{directory}: not an infoseek results directory (no {MANIFEST_NAME})"
        ) from None
    except ValueError as error:
        raise StoreConfigError(f"{path}: unreadable manifest ({error})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise StoreConfigError(f"{path}: not an infoseek results manifest")
    if manifest.get("format_version") not in READABLE_VERSIONS:
        raise StoreConfigError(
            f"{path}: store format version {manifest.get('format_version')!r}, this infoseek "
            f"reads versions {list(READABLE_VERSIONS)}"
        )
    return manifest


def _part_paths(directory: Path) -> list[Path]:
    parts = directory / PARTS_NAME
    return sorted(parts.glob("part-*.parquet")) if parts.is_dir() else []


def _read_parts(directory: Path) -> list[dict[str, Any]]:
    import pyarrow.parquet as pq

    records: list[dict[str, Any]] = []
    for path in _part_paths(directory):
        try:
            records.extend(pq.read_table(path).to_pylist())
        except Exception as error:  # pyarrow raises several types for damaged files
            raise StoreCorruptError(f"{path}: unreadable part ({error})") from None
    return records


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


def read_records(directory: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every complete trial record of the store in ``directory``: the parts, then the
    journal (a torn last line ignored), each key once."""
    read_manifest(directory)
    journal, _ = _scan(Path(directory) / TRIALS_NAME)
    return _merge(_read_parts(Path(directory)), journal)


def encode_part(records: list[dict[str, Any]]) -> Any:
    """A ``pyarrow.Table`` of ``records``: float lists in float32 except
    :data:`FULL_PRECISION_FIELDS`."""
    import pyarrow as pa

    table = pa.Table.from_pylist([_jsonable(dict(record)) for record in records])
    fields = []
    for field in table.schema:
        kind = field.type
        if (
            pa.types.is_list(kind)
            and pa.types.is_floating(kind.value_type)
            and field.name not in FULL_PRECISION_FIELDS
        ):
            kind = pa.list_(pa.float32())
        fields.append(pa.field(field.name, kind))
    return table.cast(pa.schema(fields))


def as_stored(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``records`` as a part stores them (float32 series): what :func:`read_records` returns
    for them after compaction."""
    return encode_part(records).to_pylist() if records else []


def part_keys(directory: str | os.PathLike[str]) -> list[str]:
    """The key of every row of every part, in order, duplicates included (for checks)."""
    import pyarrow.parquet as pq

    return [
        key
        for path in _part_paths(Path(directory))
        for key in pq.read_table(path, columns=["key"]).column("key").to_pylist()
    ]


def _write_part(directory: Path, records: list[dict[str, Any]]) -> Path:
    """Write ``records`` as the next part, durably (temporary file, fsync, rename)."""
    import pyarrow.parquet as pq

    parts = directory / PARTS_NAME
    parts.mkdir(exist_ok=True)
    existing = _part_paths(directory)
    number = 1 + max((int(p.stem.split("-")[1]) for p in existing), default=0)
    path = parts / f"part-{number:05d}.parquet"
    tmp = parts / f".{path.name}.tmp"
    pq.write_table(encode_part(records), tmp, compression="zstd")
    with open(tmp, "rb") as handle:
        os.fsync(handle.fileno())
    os.replace(tmp, path)
    directory_fd = os.open(parts, os.O_RDONLY)
    try:
        os.fsync(directory_fd)
    finally:
        os.close(directory_fd)
    return path


def _config_differences(stored: Mapping[str, Any], wanted: Mapping[str, Any]) -> list[str]:
    names = sorted(set(stored) | set(wanted))
    return [
        f"{name}: stored {stored.get(name)!r}, requested {wanted.get(name)!r}"
        for name in names
        if _jsonable(stored.get(name)) != _jsonable(wanted.get(name))
    ]


class ResultsStore:
    """Writer of one results directory (see the module docstring for the format).

    Use as a context manager, or call :meth:`close`. Opening validates (or creates) the
    manifest, takes the writer lock, truncates a torn last line and loads the keys of the
    trials already stored.

    Args:
        directory: The results directory (created if missing).
        config: The run configuration (JSON-serialisable mapping). A new store records it; an
            existing store must have exactly this configuration.

    Raises:
        StoreConfigError: ``directory`` holds another configuration, or is a non-empty
            directory that is not a results store.
        StoreLockedError: Another process is writing to this store.
        StoreCorruptError: ``trials.jsonl`` is damaged before its last line.
    """

    def __init__(self, directory: str | os.PathLike[str], config: Mapping[str, Any]) -> None:
        self.directory = Path(directory)
        self.config: dict[str, Any] = _jsonable(dict(config))
        manifest_path = self.directory / MANIFEST_NAME
        trials_path = self.directory / TRIALS_NAME
        if self.directory.exists() and not self.directory.is_dir():
            raise StoreConfigError(f"{self.directory}: exists and is not a directory")
        if manifest_path.exists():
            stored = read_manifest(self.directory).get("config", {})
            differences = _config_differences(stored, self.config)
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

            manifest = {
                "format": FORMAT,
                "format_version": FORMAT_VERSION,
                "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "config": self.config,
                "numerics": describe(),
            }
            tmp = manifest_path.with_suffix(".json.tmp")
            tmp.write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")
            os.replace(tmp, manifest_path)
        self._file = open(trials_path, "a+b")  # noqa: SIM115 - closed in close()
        try:
            self._lock()
            records, good_end = _scan(trials_path)
            if self._file.seek(0, os.SEEK_END) != good_end:  # torn tail of a killed writer
                self._file.truncate(good_end)
                self._file.flush()
                os.fsync(self._file.fileno())
            stored = {record["key"] for record in _read_parts(self.directory)}
        except BaseException:
            self._file.close()
            raise
        self._keys: set[str] = stored | {record["key"] for record in records}
        self._stored = stored  # keys already in parts
        if records:  # a journal left by a killed writer: keep its trials in a part
            self._compact()

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
        self._file.write(encode_record(record).encode())
        self._file.flush()
        os.fsync(self._file.fileno())
        self._keys.add(key)
        return True

    def records(self) -> list[dict[str, Any]]:
        """Every stored record (parts, then the journal; first occurrence per key)."""
        journal, _ = _scan(self.directory / TRIALS_NAME)
        return _merge(_read_parts(self.directory), journal)

    def _compact(self) -> None:
        """Move the journal's trials into a new part, then empty the journal."""
        journal, _ = _scan(self.directory / TRIALS_NAME)
        fresh = [record for record in journal if record["key"] not in self._stored]
        if fresh:
            _write_part(self.directory, fresh)
            self._stored.update(record["key"] for record in fresh)
        if journal:
            self._file.truncate(0)
            self._file.flush()
            os.fsync(self._file.fileno())

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
