"""Bad input is an error that names the argument (issue 28): a table-driven sweep of the public
constructors and of every command-line option, with wrong types and out-of-range values.

Cases that still fail in modules owned elsewhere are ``xfail(strict=True)`` with the change
they need, so the test turns red (and the marker must go) as soon as they are fixed.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import Any

import pytest

import infoseek.baselines
import infoseek.envs
from infoseek.envs.config import SearchConfig
from infoseek.experiments.bench import BenchPlan
from infoseek.experiments.cli import build_parser, main

# ---------------------------------------------------------------------------- environments
#: (keyword, bad value) -> the message must name the keyword (the issue's cases first).
ENV_CASES = [
    ("domain_size", 40),
    ("domain_size", (40,)),
    ("domain_size", (-1, 40)),
    ("domain_size", ("a", 40)),
    ("entropy_bins", 0),
    ("entropy_bins", (0, 4)),
    ("entropy_bins", (8.5, 8)),
    ("entropy_bins", "x"),
    ("n_particles", 50),
    ("n_particles", 2000.0),
    ("n_agents", 0),
    ("max_cycles", True),
    ("dt", 0),
    ("dt", float("nan")),
    ("comm_range", -1),
    ("message_loss", 2),
    ("start_center", (1,)),
    ("start_center", "bad"),
    ("start_positions", "bad"),
    ("start_positions", [[0, 0]]),
    ("target_motion", -1),
    ("sensor_kwargs", 3),
    ("render_mode", "x"),
    ("action_type", "y"),
    ("n_discrete_actions", 1),
    ("name", 3),
]


@pytest.mark.parametrize(("keyword", "value"), ENV_CASES, ids=[f"{k}={v!r}" for k, v in ENV_CASES])
def test_env_keywords_name_themselves(keyword: str, value: Any) -> None:
    with pytest.raises((TypeError, ValueError), match=keyword):
        infoseek.envs.make("bearings_v0", **{keyword: value})


@pytest.mark.parametrize("keyword", SearchConfig.config_keys())
def test_every_env_keyword_rejects_a_foreign_object_by_name(keyword: str) -> None:
    with pytest.raises((TypeError, ValueError), match=keyword):
        infoseek.envs.make("bearings_v0", **{keyword: object()})


@pytest.mark.parametrize("seed", [-1, 1.5, "a", True])
def test_reset_names_a_bad_seed(seed: Any) -> None:
    env = infoseek.envs.make("bearings_v0", n_particles=100)
    with pytest.raises((TypeError, ValueError), match="seed must be None or a non-negative"):
        env.reset(seed=seed)
    venv = infoseek.baselines.make_vec("bearings_v0", num_envs=2, n_particles=100)
    with pytest.raises((TypeError, ValueError), match="seed must be None or a non-negative"):
        venv.seed(seed)


@pytest.mark.parametrize(
    ("keyword", "value"), [("num_envs", 0), ("num_envs", "x"), ("num_envs", 2.5), ("n_workers", 0)]
)
def test_make_vec_names_its_arguments(keyword: str, value: Any) -> None:
    with pytest.raises((TypeError, ValueError), match=keyword):
        infoseek.baselines.make_vec("bearings_v0", **{keyword: value})


# ---------------------------------------------------------------------------- planners
PLANNERS = [
    "SingleNodePlanner",
    "PairwiseNodePlanner",
    "RecedingHorizonPlanner",
    "RandomPolicy",
    "LawnmowerPolicy",
]


@pytest.mark.parametrize("name", PLANNERS)
def test_planner_options_name_themselves(name: str) -> None:
    import infoseek.planners as planners

    cls = getattr(planners, name)
    env = infoseek.envs.make("bearings_v0", n_particles=100)
    unnamed = []
    for option in (f.name for f in dataclasses.fields(cls.config_class)):
        for value in (object(), "bad", -1, float("nan")):
            try:
                cls.from_env(env, **{option: value})
            except (TypeError, ValueError) as error:
                if option in str(error):
                    continue
                unnamed.append(f"{option}={value!r}: {error}")
            else:
                if value is not None and not isinstance(value, int | float):
                    unnamed.append(f"{option}={value!r}: accepted")
    assert not unnamed, unnamed


# ---------------------------------------------------------------------------- library configs
def _plan(**changes: Any) -> BenchPlan:
    fields = {
        "env": "bearings_v0",
        "env_kwargs": {},
        "steps": 3,
        "seed": 0,
        "groups": [("random", 2)],
        "trials": 1,
    }
    return BenchPlan(**{**fields, **changes})


@pytest.mark.parametrize(
    ("changes", "named"),
    [
        ({"trials": 0}, "--trials"),
        ({"trials": "3"}, "--trials"),
        ({"steps": 0}, "--steps"),
        ({"groups": [("random", 0)]}, "--agents"),
        ({"groups": [("nope", 2)]}, "nope"),
        ({"env_kwargs": {"n_agents": 3}}, "n_agents"),
    ],
)
def test_bench_plans_name_the_bad_field(changes: dict[str, Any], named: str) -> None:
    with pytest.raises((TypeError, ValueError), match=named):
        _plan(**changes)


# ---------------------------------------------------------------------------- command line
def _subcommands() -> dict[str, argparse.ArgumentParser]:
    return next(
        action.choices
        for action in build_parser()._actions
        if isinstance(action, argparse._SubParsersAction)
    )


#: Positional arguments that let each command parse.
POSITIONALS = {"plot": ["x"], "claims": ["x"], "verify": ["x"], "migrate": ["x"]}
REQUIRED = {"reproduce": ["fig2"], "train": ["--timesteps", "10", "--out", "{out}"]}


def _numeric_options() -> list[tuple[str, str]]:
    options = []
    for command, parser in sorted(_subcommands().items()):
        for action in parser._actions:
            if (
                action.option_strings
                and action.type in (int, float)
                or (action.option_strings and getattr(action.type, "__name__", "") == "_int_list")
            ):
                options.append((command, action.option_strings[0]))
    return options


@pytest.mark.parametrize(("command", "option"), _numeric_options())
def test_every_numeric_option_rejects_a_word_by_name(
    command: str, option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [command, *POSITIONALS.get(command, []), *REQUIRED.get(command, []), option, "abc"]
    assert main([a.replace("{out}", str(tmp_path / "o")) for a in argv]) == 2
    assert f"argument {option}" in capsys.readouterr().err


#: (argv, the option the one error line must name): out-of-range values and conflicts.
CLI_CASES = [
    (["demo", "--seed", "-1"], "--seed"),
    (["demo", "--agents", "0"], "--agents"),
    (["demo", "--particles", "0"], "--particles"),
    (["demo", "--steps", "0"], "--steps"),
    (["demo", "--fps", "0"], "--fps"),
    (["bench", "--seed", "-1"], "--seed"),
    (["bench", "--trials", "0"], "--trials"),
    (["bench", "--steps", "0"], "--steps"),
    (["bench", "--agents", "0"], "--agents"),
    (["bench", "--particles", "0"], "--particles"),
    (["bench", "--workers", "0"], "--workers"),
    (["bench", "--particles", "200", "--env-kwarg", "n_particles=300"], "--particles"),
    (["bench", "--env-kwarg", "sigma=1", "--env-kwarg", "sigma=2"], "--env-kwarg"),
    (["bench", "--address", "x"], "--address"),
    (["bench", "--planner", "nope"], "nope"),
    (["bench", "--env", "nope"], "nope"),
    (["reproduce", "fig1", "--seed", "-1"], "--seed"),
    (["reproduce", "fig1", "--trials", "0"], "--trials"),
    (["reproduce", "fig1", "--steps", "0"], "--steps"),
    (["reproduce", "fig1", "--particles", "0"], "--particles"),
    (["reproduce", "fig1", "--workers", "0"], "--workers"),
    (["claims", "{store}", "--alpha", "2"], "--alpha"),
    (["claims", "{store}", "--trials", "0"], "--trials"),
    (["verify", "{store}", "--trials", "0"], "--trials"),
    (["verify", "{store}", "--workers", "0"], "--workers"),
    (["verify", "{store}", "--group", "single"], "--group"),
    (["verify", "{store}", "--integrity", "--trials", "2"], "--integrity"),
    (["timing", "--repeats", "0"], "--repeats"),
    (["timing", "--json", "/proc/infoseek.json"], "--json"),
    (["train", "--timesteps", "0", "--out", "{out}"], "timesteps"),
    (["train", "--timesteps", "9", "--seed", "-1", "--out", "{out}"], "--seed"),
    (["train", "--timesteps", "9", "--agents", "0", "--out", "{out}"], "n_agents"),
    (["train", "--timesteps", "9", "--n-envs", "0", "--out", "{out}"], "n_envs"),
    (["train", "--timesteps", "9", "--torch-threads", "0", "--out", "{out}"], "--torch-threads"),
    (["train", "--timesteps", "9", "--hyper", "n_steps=abc", "--out", "{out}"], "n_steps"),
    (["train", "--timesteps", "9", "--hyper", "gamma=2", "--out", "{out}"], "gamma"),
    (["train", "--timesteps", "9", "--hyper", "nope=1", "--out", "{out}"], "nope"),
    (["train", "--timesteps", "9", "--hyper", "gamma=0.9", "--hyper", "gamma=0.8"], "gamma"),
    (
        ["train", "--timesteps", "9", "--particles", "200", "--env-kwarg", "n_particles=300"],
        "--particles",
    ),
]


@pytest.mark.parametrize(("argv", "named"), CLI_CASES, ids=[" ".join(a) for a, _ in CLI_CASES])
def test_cli_errors_name_the_option_before_any_work(
    argv: list[str], named: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    store = Path(__file__).resolve().parents[1] / "experiments" / "results" / "fig1" / "store"
    out = tmp_path / "out"
    argv = [a.replace("{out}", str(out)).replace("{store}", str(store)) for a in argv]
    if argv[0] == "train" and "--out" not in argv:
        argv += ["--out", str(out)]
    started = time.perf_counter()
    assert main(argv) == 2
    assert time.perf_counter() - started < 10.0  # before any work
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"infoseek {argv[0]}: error: "), err
    assert named in err[0], err
    assert not out.exists()  # nothing written


def test_bench_help_lists_every_planner(capsys: pytest.CaptureFixture[str]) -> None:
    from infoseek.experiments.policies import PLANNER_NAMES

    assert main(["bench", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for name in PLANNER_NAMES:
        assert name in text
