"""Command-line argument pieces shared by several ``infoseek`` subcommands."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any


def key_value(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` with VALUE parsed as JSON when possible (an argparse ``type``)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key, json.loads(value)
    except ValueError:
        return key, value


def add_environment_overrides(parser: argparse.ArgumentParser) -> None:
    """``--particles N`` and repeatable ``--env-kwarg KEY=VALUE`` (environment keywords)."""
    parser.add_argument(
        "--particles", type=int, default=None, help="particles per belief (default: env's)"
    )
    parser.add_argument(
        "--env-kwarg",
        type=key_value,
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="extra environment keyword (VALUE parsed as JSON), repeatable",
    )


def check_writable_directory(path: Path, option: str = "--out") -> None:
    """Raise ``ValueError`` unless ``path`` is (or can be created as) a writable directory.

    Nothing is created: the check runs before any work, so a bad ``--out`` fails at once.
    """
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise ValueError(f"{option}: {path} exists and is not a directory")
        if not os.access(path, os.W_OK | os.X_OK):
            raise ValueError(f"{option}: {path} is not writable")
        return
    parent = _existing_parent(path)
    if not parent.is_dir():
        raise ValueError(f"{option}: cannot create {path}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{option}: cannot create {path}: {parent} is not writable")


def check_writable_file(path: Path, option: str) -> None:
    """Raise ``ValueError`` unless the file ``path`` can be written (its folder created)."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{option}: {path} is a directory, expected a file path")
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"{option}: {path} is not writable")
    check_writable_directory(path.parent if str(path.parent) else Path("."), option)


def check_results_directory(path: Path) -> None:
    """Raise ``ValueError`` unless ``path`` is an existing directory (a results store)."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{path}: no such results directory")
    if not path.is_dir():
        raise ValueError(f"{path}: is a file, expected a results directory written by bench")


def _existing_parent(path: Path) -> Path:
    for parent in path.absolute().parents:
        if parent.exists():
            return parent
    return Path("/")
