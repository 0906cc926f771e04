"""The command line fails with one line and exit status 2, before doing any work."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import infoseek.experiments.cli as cli
from infoseek.experiments.cli import main
from infoseek.experiments.store import MANIFEST_NAME, read_manifest

TESTS_DIR = Path(__file__).resolve().parent


def _one_error_line(capsys: pytest.CaptureFixture[str], command: str) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"infoseek {command}: error: "), err
    return err[0]


@pytest.fixture
def blocked(tmp_path: Path) -> Path:
    """A path that cannot be created, even by root: its parent is a regular file."""
    parent = tmp_path / "a-file"
    parent.write_text("not a directory")
    return parent / "out"


@pytest.mark.parametrize(
    ("command", "argv"),
    [
        ("demo", ["demo", "--steps", "1", "--particles", "100", "--out", "{out}"]),
        (
            "bench",
            ["bench", "--trials", "1", "--steps", "1", "--particles", "100", "--out", "{out}"],
        ),
        ("reproduce", ["reproduce", "fig2", "--steps", "1", "--out", "{out}"]),
        ("train", ["train", "--algo", "ppo", "--timesteps", "10", "--out", "{out}"]),
        ("train", ["train", "--algo", "dagger", "--out", "{out}"]),
        (
            "timing",
            ["timing", "--repeats", "1", "--only", "env_step_bearings_4", "--json", "{out}"],
        ),
    ],
)
def test_an_unwritable_out_fails_at_once(
    command: str, argv: list[str], blocked: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    started = time.perf_counter()
    assert main([a.replace("{out}", str(blocked)) for a in argv]) == 2
    assert time.perf_counter() - started < 5.0  # before any work
    line = _one_error_line(capsys, command)
    assert str(blocked.parent) in line
    assert not blocked.exists()


def test_plot_checks_its_output_and_input_folders(
    blocked: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    store = Path(__file__).resolve().parents[1] / "experiments" / "results" / "fig1" / "store"
    assert main(["plot", str(store), "--out", str(blocked)]) == 2
    assert "--out" in _one_error_line(capsys, "plot")
    for command in ("plot", "claims", "verify"):
        assert main([command, str(blocked.parent)]) == 2  # a file, not a results folder
        assert "expected a results directory" in _one_error_line(capsys, command)
        assert main([command, str(tmp_path / "missing")]) == 2
        _one_error_line(capsys, command)


@pytest.mark.parametrize("fps", ["0", "-2"])
def test_demo_rejects_a_non_positive_frame_rate_up_front(
    fps: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["demo", "--fps", fps, "--out", str(tmp_path / "d")]) == 2
    assert "--fps must be > 0" in _one_error_line(capsys, "demo")
    assert not (tmp_path / "d").exists()


def test_bench_validates_the_whole_run_before_writing_the_store(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    tiny = ["--trials", "1", "--steps", "1", "--particles", "100", "--out", str(out)]
    assert main(["bench", "--env-kwarg", "n_particle=100", *tiny]) == 2
    assert "n_particle" in _one_error_line(capsys, "bench")
    # one group (pairwise with one agent) is impossible: nothing runs, nothing is written
    assert (
        main(["bench", "--planner", "single", "--planner", "pairwise", "--agents", "1", *tiny]) == 2
    )
    assert "pairwise with 1 agent(s)" in _one_error_line(capsys, "bench")
    assert main(["bench", "--planner", "joint", "--agents", "4", *tiny]) == 2
    assert "joint with 4 agent(s)" in _one_error_line(capsys, "bench")
    assert not out.exists()


def test_the_default_spelled_out_is_the_same_configuration(tmp_path: Path) -> None:
    out = tmp_path / "run"
    tiny = ["bench", "--agents", "2", "--trials", "1", "--steps", "1", "--workers", "1"]
    assert main([*tiny, "--particles", "2000", "--no-progress", "--out", str(out)]) == 0
    assert read_manifest(out)["config"]["env_kwargs"] == {}
    assert main([*tiny, "--no-progress", "--out", str(out)]) == 0  # not "another configuration"


def test_bench_policy_without_the_rl_extra_says_which_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    model = Path(__file__).resolve().parents[1] / "baselines" / "models"
    model = next(model.glob("*/model.zip"))
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # import fails
    argv = ["bench", "--policy", str(model), "--trials", "1", "--out", str(tmp_path / "p")]
    assert main(argv) == 2
    assert "pip install 'infoseek[rl]'" in _one_error_line(capsys, "bench")
    assert not (tmp_path / "p" / MANIFEST_NAME).exists()


def test_ctrl_c_is_one_line_and_status_130(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def interrupted(args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "run_timing", interrupted)
    assert main(["timing", "--repeats", "1"]) == 130
    assert capsys.readouterr().err.strip() == "infoseek timing: interrupted"


def _descendants(pid: int) -> set[int]:
    children = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                children.add(int(entry.name))
    return children.union(*(_descendants(child) for child in children))


def _running(pid: int) -> bool:
    try:
        state = (Path(f"/proc/{pid}") / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _start_two_worker_bench(tmp_path: Path) -> tuple[subprocess.Popen[bytes], Path]:
    """A slow two-worker bench in a subprocess, returned once its first trial is journaled."""
    environ = {**os.environ, "PYTHONPATH": str(TESTS_DIR), "INFOSEEK_TEST_SLEEP": "0.2"}
    args = ["bench", "--planner", "test_bench:sleepy_random_policy", "--agents", "2"]
    args += ["--trials", "20", "--steps", "5", "--particles", "100", "--workers", "2"]
    process = subprocess.Popen(
        [sys.executable, "-m", "infoseek.experiments", *args, "--no-progress"]
        + ["--out", str(tmp_path / "run")],
        env=environ,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    journal = tmp_path / "run" / "trials.jsonl"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (journal.exists() and journal.stat().st_size):
        time.sleep(0.05)
    return process, journal


@pytest.mark.skipif(sys.platform == "win32", reason="sends POSIX signals")
def test_a_terminated_bench_stores_its_finished_trials_in_a_part(tmp_path: Path) -> None:
    process, journal = _start_two_worker_bench(tmp_path)
    assert journal.stat().st_size  # at least one trial finished
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=60) == cli.EXIT_INTERRUPTED
    assert journal.stat().st_size == 0  # compacted: the trials are in a part
    assert list((tmp_path / "run" / "parts").glob("part-*.parquet"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_killed_multi_process_bench_leaves_no_workers(tmp_path: Path) -> None:
    process, journal = _start_two_worker_bench(tmp_path)
    workers = _descendants(process.pid)
    assert len(workers) >= 2  # the pool is running
    process.send_signal(signal.SIGKILL)
    process.wait()
    deadline = time.monotonic() + 30  # generous on a loaded machine
    while time.monotonic() < deadline and any(_running(pid) for pid in workers):
        time.sleep(0.1)
    assert not [pid for pid in workers if _running(pid)]
