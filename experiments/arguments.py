"""Command-line argument pieces shared by several ``infoseek`` subcommands."""

from __future__ import annotations

import argparse
import json
import os
import tempfile
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


def environment_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The environment keywords of ``--env-kwarg`` and ``--particles``.

    Raises:
        ValueError: A keyword given twice with different values, or ``--particles`` together
            with ``--env-kwarg n_particles=...`` (conflicting options are an error, never a
            silent choice), or ``--particles`` below 1.
    """
    kwargs: dict[str, Any] = {}
    for key, value in args.env_kwarg:
        if key in kwargs and kwargs[key] != value:
            raise ValueError(
                f"--env-kwarg {key} given twice ({kwargs[key]!r} and {value!r}); give it once"
            )
        kwargs[key] = value
    if args.particles is not None:
        if args.particles < 1:
            raise ValueError(f"--particles must be >= 1, got {args.particles}")
        if "n_particles" in kwargs:
            raise ValueError(
                f"--particles {args.particles} and --env-kwarg n_particles="
                f"{kwargs['n_particles']!r} both set the particle count; give one of them"
            )
        kwargs["n_particles"] = args.particles
    return kwargs


def check_seed(seed: int, option: str = "--seed") -> None:
    """Raise ``ValueError`` unless ``seed`` is a non-negative integer (NumPy's seeds)."""
    if seed < 0:
        raise ValueError(f"{option} must be a non-negative integer, got {seed}")


def check_writable_directory(path: Path, option: str = "--out") -> None:
    """Raise ``ValueError`` unless ``path`` is (or can be created as) a writable directory.

    Nothing is left behind: the check runs before any work, so a bad ``--out`` fails at once.
    Writability is probed by creating (and removing) a temporary file in ``path`` or its
    nearest existing parent, since permission bits do not tell (root may write anywhere by
    mode, but not into ``/proc`` or a read-only mount).
    """
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise ValueError(f"{option}: {path} exists and is not a directory")
        _probe(path, f"{option}: {path} is not writable")
        return
    parent = _existing_parent(path)
    if not parent.is_dir():
        raise ValueError(f"{option}: cannot create {path}: {parent} is not a directory")
    _probe(parent, f"{option}: cannot create {path}: {parent} is not writable")


def _probe(directory: Path, message: str) -> None:
    """Raise ``ValueError(message + reason)`` unless a file can be created in ``directory``."""
    if not os.access(directory, os.W_OK | os.X_OK):
        raise ValueError(message)
    try:
        with tempfile.TemporaryFile(dir=directory, prefix=".infoseek-probe-"):
            pass
    except OSError as error:
        raise ValueError(f"{message} ({error.strerror or error})") from None


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
