"""Append-only results store of the Monte Carlo benchmark (``infoseek bench``).

A store is a directory holding two files:

``manifest.json``
    One JSON object, written once (atomically: temporary file + rename) when the store is
    created. Its ``config`` member is the configuration that defines the run and that every
    trial in the store shares::

        {
          "format": "infoseek-bench-store",
          "format_version": 1,
          "created": "2006-12-13T12:00:00+00:00",      # informational, never compared
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

``trials.jsonl``
    JSON Lines, one object per finished trial, appended in completion order. Each line is
    written with a single ``write`` followed by ``flush`` and ``os.fsync``, so a finished
    trial survives a crash. A record carries at least ``key`` (a string, unique in the store,
    ``"<planner>/agents=<n>/trial=<k>"``), ``planner``, ``n_agents`` and ``trial``; the
    benchmark adds the per-step metrics (see :mod:`infoseek.experiments.bench`). Non-finite
    floats are stored as ``null`` (strict JSON).

    A process killed in the middle of a ``write`` leaves a *torn* last line (no trailing
    newline, or not valid JSON). Readers ignore it; a writer opening the store truncates the
    file back to the end of the last complete line before appending. A malformed line that is
    *not* the last one means the file was damaged by something else: reading fails with
    :class:`StoreCorruptError` rather than silently dropping data. If a key occurs more than
    once (only possible through outside edits), the first occurrence wins.

A writer holds an exclusive ``fcntl`` lock on ``trials.jsonl`` while the store is open, so two
runs cannot append to the same directory at once (the second fails with a clear message).
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
FORMAT_VERSION = 1
MANIFEST_NAME = "manifest.json"
TRIALS_NAME = "trials.jsonl"


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
    if manifest.get("format_version") != FORMAT_VERSION:
        raise StoreConfigError(
            f"{path}: store format version {manifest.get('format_version')!r}, this infoseek "
            f"reads version {FORMAT_VERSION}"
        )
    return manifest


def read_records(directory: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every complete trial record of the store in ``directory`` (a torn last line ignored)."""
    read_manifest(directory)
    records, _ = _scan(Path(directory) / TRIALS_NAME)
    return records


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
            manifest = {
                "format": FORMAT,
                "format_version": FORMAT_VERSION,
                "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                "config": self.config,
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
        except BaseException:
            self._file.close()
            raise
        self._keys: set[str] = {record["key"] for record in records}

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
        """Every stored record (first occurrence per key, file order)."""
        records, _ = _scan(self.directory / TRIALS_NAME)
        return records

    def close(self) -> None:
        """Release the lock and close the file (idempotent)."""
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._keys))
