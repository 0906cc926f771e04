"""The ``infoseek`` parser: every subcommand listed with its help, in order, and run by the
handler this module holds under its name when the parser is built."""

from __future__ import annotations

import argparse

import pytest

import infoseek.experiments.cli as cli
from infoseek.experiments.cli import main

#: Subcommand -> (its handler's name in the cli module, the least argv it parses).
SUBCOMMANDS = {
    "demo": ("run_demo", []),
    "timing": ("run_timing", []),
    "bench": ("run_bench_command", []),
    "plot": ("run_plot_command", ["results"]),
    "reproduce": ("run_reproduce_command", ["fig1"]),
    "page": ("run_page_command", ["fig1"]),
    "claims": ("run_claims", ["results"]),
    "verify": ("run_verify_command", ["results"]),
    "train": ("run_train", ["--out", "run"]),
    "migrate": ("run_migrate_command", ["results"]),
}


def test_help_lists_every_subcommand_in_order(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    listed = [
        line.split()[0]
        for line in capsys.readouterr().out.splitlines()
        if line.startswith("    ") and not line.startswith("     ")
    ]
    assert listed == list(SUBCOMMANDS)


def test_each_subcommand_runs_the_handler_replaced_after_import(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A handler replaced on the module after it is imported is the one that runs (the parser
    reads the handlers when it is built)."""
    ran: list[str] = []

    def replacement(name: str, code: int) -> object:
        def handler(args: argparse.Namespace) -> int:
            assert args.command == name
            ran.append(name)
            return code

        return handler

    for code, (name, (handler_name, _)) in enumerate(SUBCOMMANDS.items(), start=10):
        monkeypatch.setattr(cli, handler_name, replacement(name, code))
    for code, (name, (_, argv)) in enumerate(SUBCOMMANDS.items(), start=10):
        assert main([name, *argv]) == code
    assert ran == list(SUBCOMMANDS)
