"""Self-checking encodings of the results store's text files (manifest and journal lines).

Every byte of a sealed file is covered, so any change made outside infoseek is found:

* **Digest** of bytes: ``"sha256:<64 hex digits>"`` (:func:`digest`).
* **Sealed JSON document** (the manifest): the canonical serialisation of a JSON object
  (``json.dumps(obj, indent=2, sort_keys=True) + "\\n"``, strict JSON) whose member
  ``"checksum"`` is the digest of the canonical serialisation of the other members. A file is
  accepted only if it *is* that canonical serialisation (so a changed space or digit is caught
  even where the parsed value would survive) and its checksum matches.
* **Checked JSON line** (a journal line): ``json.dumps(record, sort_keys=True) + "\\n"`` with
  the member :data:`LINE_CHECKSUM` holding the first 16 hex digits of the SHA-256 of the
  canonical line of the record without it. Again the line must be canonical and match.

Nothing here knows about files: the functions raise :class:`ChecksumError` with what is
wrong, and the store adds the file name.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

__all__ = [
    "LINE_CHECKSUM",
    "ChecksumError",
    "decode_checked_line",
    "decode_sealed",
    "digest",
    "encode_checked_line",
    "encode_sealed",
]

#: Member of a journal line holding the line's checksum.
LINE_CHECKSUM = "_sha256"
#: Member of a sealed document holding its checksum.
DOCUMENT_CHECKSUM = "checksum"
_PREFIX = "sha256:"


class ChecksumError(ValueError):
    """Bytes that are not what infoseek wrote (the message says what is wrong)."""


def digest(data: bytes) -> str:
    """``"sha256:<hex>"`` of ``data``."""
    return _PREFIX + hashlib.sha256(data).hexdigest()


def _document(body: Mapping[str, Any]) -> bytes:
    return (json.dumps(body, indent=2, sort_keys=True, allow_nan=False) + "\n").encode()


def encode_sealed(body: Mapping[str, Any]) -> bytes:
    """The sealed document of the JSON object ``body`` (which must not have ``"checksum"``)."""
    if DOCUMENT_CHECKSUM in body:
        raise ValueError(f"body: must not have a {DOCUMENT_CHECKSUM!r} member")
    return _document({**body, DOCUMENT_CHECKSUM: digest(_document(body))})


def decode_sealed(data: bytes) -> dict[str, Any]:
    """The body of a sealed document (without ``"checksum"``).

    Raises:
        ChecksumError: Not valid JSON, not a JSON object, not in canonical form, or a checksum
            that does not match the content.
    """
    document = _parse_object(data)
    claimed = document.pop(DOCUMENT_CHECKSUM, None)
    if claimed is None:
        raise ChecksumError(f"no {DOCUMENT_CHECKSUM!r} member")
    body = document
    if _document({**body, DOCUMENT_CHECKSUM: claimed}) != data:
        raise ChecksumError("not in the form infoseek writes (edited outside infoseek?)")
    if claimed != digest(_document(body)):
        raise ChecksumError("checksum does not match the content (modified or damaged)")
    return body


def _line(record: Mapping[str, Any]) -> bytes:
    return (json.dumps(record, sort_keys=True, allow_nan=False) + "\n").encode()


def _line_digest(record: Mapping[str, Any]) -> str:
    return hashlib.sha256(_line(record)).hexdigest()[:16]


def encode_checked_line(record: Mapping[str, Any]) -> bytes:
    """One journal line (with its trailing newline) of the JSON object ``record``."""
    if LINE_CHECKSUM in record:
        raise ValueError(f"record: must not have a {LINE_CHECKSUM!r} member")
    return _line({**record, LINE_CHECKSUM: _line_digest(record)})


def decode_checked_line(line: bytes) -> dict[str, Any]:
    """The record of one journal line (``line`` with its trailing newline).

    Raises:
        ChecksumError: Not a JSON object, no checksum, not canonical, or a checksum that does
            not match.
    """
    record = _parse_object(line)
    claimed = record.pop(LINE_CHECKSUM, None)
    if not isinstance(claimed, str):
        raise ChecksumError(f"no {LINE_CHECKSUM!r} checksum")
    if _line({**record, LINE_CHECKSUM: claimed}) != line:
        raise ChecksumError("not in the form infoseek writes (edited outside infoseek?)")
    if claimed != _line_digest(record):
        raise ChecksumError("checksum does not match the content (modified or damaged)")
    return record


def _parse_object(data: bytes) -> dict[str, Any]:
    try:
        value = json.loads(data, parse_constant=_reject_constant)
    except ValueError as error:  # JSONDecodeError and UnicodeDecodeError
        raise ChecksumError(f"not valid JSON ({error})") from None
    if not isinstance(value, dict):
        raise ChecksumError("not a JSON object")
    return value


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not strict JSON")
