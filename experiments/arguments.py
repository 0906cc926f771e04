"""Command-line argument pieces shared by several ``infoseek`` subcommands."""

from __future__ import annotations

import argparse
import json
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
