"""Every ``infoseek`` command runs with one BLAS/OpenMP thread unless INFOSEEK_THREADS says
otherwise (issue: 1.5-6x slower tools with the default two OpenBLAS threads on 2 cores)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import pytest
from threadpoolctl import threadpool_info

import infoseek.experiments.cli as cli
from infoseek.experiments.cli import build_parser, main
from infoseek.experiments.threads import THREADS_VARIABLE

#: An argument list that reaches each command's handler.
COMMANDS = {
    "demo": ["demo"],
    "timing": ["timing"],
    "bench": ["bench"],
    "plot": ["plot", "x"],
    "reproduce": ["reproduce", "fig2"],
    "page": ["page", "fig1"],
    "claims": ["claims", "x"],
    "verify": ["verify", "x"],
    "train": ["train", "--timesteps", "1", "--out", "x"],
    "migrate": ["migrate", "x"],
}


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return next(
        action.choices
        for action in parser._actions
        if isinstance(action, argparse._SubParsersAction)
    )


def _blas_threads() -> list[int]:
    return [info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"]


def test_the_table_covers_every_command() -> None:
    assert set(_commands(build_parser())) == set(COMMANDS)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_runs_with_one_blas_thread(
    command: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(THREADS_VARIABLE, raising=False)
    outside = _blas_threads()
    seen: list[list[int]] = []

    def handler(args: argparse.Namespace) -> int:
        seen.append(_blas_threads())
        return 0

    parser = build_parser()
    _commands(parser)[command].set_defaults(handler=handler)
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    assert main(COMMANDS[command]) == 0
    assert seen and set(seen[0]) == {1}
    assert _blas_threads() == outside  # restored after the command


@pytest.mark.parametrize(("value", "expected"), [("0", None), ("2", 2)])
def test_infoseek_threads_opts_out(
    value: str, expected: int | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(THREADS_VARIABLE, value)
    outside = _blas_threads()
    seen: list[list[int]] = []
    monkeypatch.setattr(cli, "run_timing", lambda args: seen.append(_blas_threads()) or 0)
    assert main(["timing"]) == 0
    assert seen == [outside if expected is None else [expected] * len(outside)]


def test_a_bad_infoseek_threads_is_one_error_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv(THREADS_VARIABLE, "two")
    monkeypatch.setattr(cli, "run_timing", lambda args: 0)
    assert main(["timing"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and THREADS_VARIABLE in err[0] and "'two'" in err[0]


def test_the_console_entry_point_sets_one_thread_before_numpy_loads() -> None:
    """Through the entry point, NumPy's OpenBLAS starts with one thread, and so do the worker
    processes the command starts (the variables are inherited); a user's own setting wins."""
    script = (
        "import json, os, sys\n"
        "from infoseek.experiments.launch import limit_threads_early\n"
        "limit_threads_early()\n"
        "import numpy\n"
        "from threadpoolctl import threadpool_info\n"
        "print(json.dumps([[i['num_threads'] for i in threadpool_info()],"
        " os.environ['OMP_NUM_THREADS']]))\n"
    )
    names = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", THREADS_VARIABLE)
    environ = {k: v for k, v in os.environ.items() if k not in names}
    for extra, expected in (({}, [[1], "1"]), ({"OMP_NUM_THREADS": "2"}, [[1], "2"])):
        run = subprocess.run(
            [sys.executable, "-c", script],
            env={**environ, **extra},
            capture_output=True,
            text=True,
            check=True,
        )
        threads, omp = json.loads(run.stdout)
        assert [sorted(set(threads)), omp] == expected
