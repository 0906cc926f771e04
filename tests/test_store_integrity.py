"""Damage to a results store is found, named and never read as numbers.

A store of two parts and a journal is damaged at seeded offsets (bytes overwritten, files cut
short, files removed); every damage must make the readers fail with the damaged file's name
(``read_rows``, ``infoseek verify --integrity``, ``infoseek claims`` with exit status 2 and
nothing on stdout). The one documented exception is the journal's tail: a journal cut at a
line boundary reads as a run stopped earlier, and a last line that lost its newline as a torn
write (a warning); both give a prefix of the stored trials, never a changed one.
"""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from infoseek.experiments import store
from infoseek.experiments.checksums import (
    ChecksumError,
    decode_checked_line,
    decode_sealed,
    encode_checked_line,
    encode_sealed,
)
from infoseek.experiments.cli import main
from infoseek.experiments.integrity import check_integrity
from infoseek.experiments.store import (
    MANIFEST_NAME,
    PARTS_NAME,
    TRIALS_NAME,
    ResultsStore,
    StoreCorruptError,
    StoreWarning,
    read_rows,
)

STEPS = 6
CONFIG = {"env": "bearings_v0", "env_kwargs": {}, "steps": STEPS, "seed": 0, "version": "t"}


def _record(planner: str, trial: int, rng: np.random.Generator) -> dict[str, Any]:
    mass = np.sort(rng.uniform(0, 1, STEPS + 1)).tolist()
    return {
        "key": store.trial_key(planner, 2, trial),
        "planner": planner,
        "n_agents": 2,
        "trial": trial,
        "env_seed": 1000 + trial,
        "policy_seed": 7 * trial,
        "mass_agent0": mass,
        "error_team": rng.uniform(0, 20, STEPS + 1).tolist(),
        "plan_time": [0.001] * STEPS,
    }


@pytest.fixture(scope="module")
def pristine(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two parts (single and pairwise, 12 trials each) and a journal of 4 more trials."""
    directory = tmp_path_factory.mktemp("pristine") / "store"
    rng = np.random.default_rng(0)
    for planner in ("single", "pairwise"):
        with ResultsStore(directory, CONFIG) as writer:
            for trial in range(12):
                writer.append(_record(planner, trial, rng))
    journal = b"".join(
        store.encode_journal_line(_record("pairwise", trial, rng)) for trial in range(12, 16)
    )
    (directory / TRIALS_NAME).write_bytes(journal)
    return directory


def _copy(pristine: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "store"
    shutil.copytree(pristine, copy)
    return copy


def _targets(directory: Path) -> list[Path]:
    parts = sorted((directory / PARTS_NAME).glob("part-*.parquet"))
    assert len(parts) == 2
    return [*parts, directory / MANIFEST_NAME, directory / TRIALS_NAME]


def _overwrite(path: Path, offset: int, length: int, rng: np.random.Generator) -> None:
    data = bytearray(path.read_bytes())
    end = min(offset + length, len(data))
    flips = rng.integers(1, 256, end - offset, dtype=np.uint8)  # never the same byte
    data[offset:end] = (np.frombuffer(bytes(data[offset:end]), np.uint8) ^ flips).tobytes()
    path.write_bytes(bytes(data))


def _damages(rng: np.random.Generator) -> list[tuple[int, str, int, int]]:
    """(target index, kind, offset or length, byte count) for the seeded damage cases."""
    cases: list[tuple[int, str, int, int]] = []
    for target in range(4):
        for _ in range(30):
            cases.append(
                (target, "overwrite", int(rng.integers(0, 2**31)), int(rng.integers(1, 9)))
            )
        for _ in range(6):
            cases.append((target, "truncate", int(rng.integers(0, 2**31)), 0))
        cases.append((target, "remove", 0, 0))
    return cases


DAMAGES = _damages(np.random.default_rng(2026))


def _apply(directory: Path, case: tuple[int, str, int, int], rng: np.random.Generator) -> Path:
    target, kind, where, count = case
    path = _targets(directory)[target]
    size = path.stat().st_size
    if kind == "overwrite":
        _overwrite(path, where % size, count, rng)
    elif kind == "truncate":
        path.write_bytes(path.read_bytes()[: where % size])
    else:
        path.unlink()
    return path


def _journal_prefix_only(directory: Path, pristine_records: list[dict[str, Any]]) -> bool:
    """Whether the damaged journal reads as a prefix of the pristine trials (a run stopped
    earlier): the documented, silent case of a journal cut at a line boundary."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StoreWarning)
        records = read_rows(directory)
    return records == pristine_records[: len(records)] and len(records) >= 24


@pytest.mark.parametrize("case", DAMAGES, ids=[f"{t}-{k}-{w % 997}" for t, k, w, _ in DAMAGES])
def test_every_damage_is_named_and_never_read_as_numbers(
    case: tuple[int, str, int, int], pristine: Path, tmp_path: Path, capsys: Any
) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", StoreWarning)
        pristine_records = read_rows(pristine)
    assert len(pristine_records) == 28
    directory = _copy(pristine, tmp_path)
    path = _apply(directory, case, np.random.default_rng(case[2] % 2**32))
    name = directory.name if path.name == MANIFEST_NAME and case[1] == "remove" else path.name
    journal = path.name == TRIALS_NAME
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", StoreWarning)
            read_rows(directory)
    except StoreCorruptError as error:
        assert name in str(error) and "\n" not in str(error)
    except StoreWarning as warning:  # a journal's last line that lost its newline
        assert journal and TRIALS_NAME in str(warning)
        assert _journal_prefix_only(directory, pristine_records)
    except store.StoreConfigError as error:  # the manifest removed: not a store any more
        assert path.name == MANIFEST_NAME and str(directory) in str(error)
    else:
        assert journal and case[1] in ("truncate", "remove")
        assert _journal_prefix_only(directory, pristine_records)
        return
    code = main(["claims", str(directory)])
    out, err = capsys.readouterr()
    if journal and code == 0:  # the torn-tail warning case: claims ran on the prefix
        assert "warning" in err and TRIALS_NAME in err
        return
    assert code == 2 and out == "", out  # never a number
    assert err.startswith("infoseek claims: error: ") and name in err
    if path.name != MANIFEST_NAME or case[1] != "remove":
        report = check_integrity(directory)
        assert report.problems and any(name in problem for problem in report.problems)
        assert main(["verify", "--integrity", str(directory)]) == 2
        assert name in capsys.readouterr().err


def test_the_pristine_store_is_intact(pristine: Path, capsys: Any) -> None:
    report = check_integrity(pristine)
    assert (report.problems, report.parts, report.rows, report.journal_records) == ([], 2, 24, 4)
    assert main(["verify", "--integrity", str(pristine)]) == 0
    assert "intact" in capsys.readouterr().out
    manifest = store.read_manifest(pristine)
    assert manifest["format_version"] == 3 and sorted(manifest["parts"]) == [
        "part-00001.parquet",
        "part-00002.parquet",
    ]


def test_parts_are_written_with_parquet_page_checksums(pristine: Path) -> None:
    """Damage inside a data page is caught by Parquet's own page checksums too (not only by
    the manifest's whole-file hash)."""
    import pyarrow.parquet as pq

    path = sorted((pristine / PARTS_NAME).glob("part-*.parquet"))[0]
    data = bytearray(path.read_bytes())
    data[40] ^= 0xFF  # inside the first column chunk's first page
    import pyarrow as pa

    with pytest.raises(OSError, match="CRC checksum verification failed"):
        pq.read_table(pa.BufferReader(bytes(data)), page_checksum_verification=True)
    with pytest.raises(StoreCorruptError, match="unreadable"):
        store.decode_part(path, bytes(data), None)


def test_sealed_encodings_reject_any_changed_byte() -> None:
    body = {"config": {"steps": 3, "sigma": 0.05}, "parts": {}}
    sealed = encode_sealed(body)
    assert decode_sealed(sealed) == body
    line = encode_checked_line({"key": "a", "v": [0.1, None]})
    assert decode_checked_line(line) == {"key": "a", "v": [0.1, None]}
    for data, decode in ((sealed, decode_sealed), (line, decode_checked_line)):
        for offset in range(len(data)):
            damaged = bytearray(data)
            damaged[offset] ^= 0x20  # e.g. a space to NUL, a digit to another character
            with pytest.raises(ChecksumError):
                decode(bytes(damaged))
    with pytest.raises(ChecksumError, match="strict JSON"):
        decode_checked_line(b'{"_sha256": "0", "key": NaN}\n')


def test_a_part_the_manifest_does_not_list_is_refused_by_readers_and_repaired_by_writers(
    pristine: Path, tmp_path: Path
) -> None:
    """A writer stopped between adding a part and recording it in the manifest leaves the part
    unlisted with its trials still in the journal: readers refuse it, the next writer removes
    it and compacts the journal again, each trial once."""
    directory = _copy(pristine, tmp_path)
    journal = store._scan(directory / TRIALS_NAME)[0]
    store._write_part(directory, store.encode_part(journal))  # not recorded in the manifest
    with pytest.raises(StoreCorruptError, match="part-00003.parquet: a part the manifest does"):
        read_rows(directory)
    with ResultsStore(directory, CONFIG):
        pass
    keys = store.part_keys(directory)
    assert len(keys) == 28 == len(set(keys))
    assert check_integrity(directory).problems == []
    foreign = directory / PARTS_NAME / "part-00009.parquet"
    shutil.copy(directory / PARTS_NAME / "part-00001.parquet", foreign)
    with pytest.raises(StoreCorruptError, match="part-00009.parquet.*not in the journal"):
        ResultsStore(directory, CONFIG)


def test_an_older_store_is_sealed_by_the_next_writer_and_by_migrate(
    pristine: Path, tmp_path: Path, capsys: Any
) -> None:
    """A format 2 store (parts without checksums, a plain JSON journal) is read as it is and
    gets its checksums from the next writer (here ``infoseek migrate``), numbers unchanged."""
    directory = _copy(pristine, tmp_path)
    records = read_rows(directory)
    manifest = store.read_manifest(directory)
    del manifest["parts"]
    manifest["format_version"] = 2
    (directory / MANIFEST_NAME).write_text(json.dumps(manifest, indent=2, sort_keys=True))
    lines = [json.loads(line) for line in (directory / TRIALS_NAME).read_text().splitlines()]
    plain = [{k: v for k, v in line.items() if k != "_sha256"} for line in lines]
    (directory / TRIALS_NAME).write_text("".join(json.dumps(r) + "\n" for r in plain))
    assert read_rows(directory) == records
    report = check_integrity(directory)
    assert report.problems == [] and any("without checksums" in n for n in report.notes)
    assert main(["migrate", str(directory)]) == 0
    assert "format 3 with checksums" in capsys.readouterr().out
    assert store.read_manifest(directory)["format_version"] == 3
    assert read_rows(directory) == store.as_stored(records)
    assert check_integrity(directory).problems == []


COMMITTED = Path(__file__).resolve().parents[1] / "experiments" / "results"


@pytest.mark.parametrize(
    "directory",
    sorted(str(p.parent.relative_to(COMMITTED)) for p in COMMITTED.rglob(MANIFEST_NAME)),
)
def test_committed_stores_are_sealed_and_intact(directory: str) -> None:
    report = check_integrity(COMMITTED / directory)
    assert report.sealed and report.problems == [] and report.rows > 0, report
