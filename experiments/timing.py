"""``infoseek timing``: speed of the hot paths, measured on the machine it runs on.

Each benchmark runs a warm-up call, then ``--repeats`` timed calls of :func:`time.perf_counter`;
the table reports the median and the interquartile range in milliseconds, plus the machine
(CPU model, logical cores, Python and NumPy versions). Benchmarks:

* ``mi_single_fast``: single-node mutual information (eq. 20) of 64 candidate poses for a
  bearing sensor and N = 10,000 particles (a random, non-uniform belief), the FFT fast path;
* ``mi_single_general``: the same inputs through the general quadrature path, and the ratio;
* ``plan_single_10``, ``plan_pairwise_10``: one ``act`` call of ``SingleNodePlanner`` and of
  ``PairwiseNodePlanner`` for 10 airplanes on ``bearings_v0`` (2000 planning particles),
  timed over successive steps of one seeded episode;
* ``env_step_bearings_4``, ``env_step_beacon_4``: one ``env.step`` with 4 agents and 2000
  particles each and random actions (no rendering).

Usage: ``infoseek timing [--repeats R] [--only NAME ...] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

BENCHMARKS = (
    "mi_single_fast",
    "mi_single_general",
    "plan_single_10",
    "plan_pairwise_10",
    "env_step_bearings_4",
    "env_step_beacon_4",
)


def add_timing_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek timing``."""
    parser.add_argument("--repeats", type=int, default=30, help="timed calls per benchmark")
    parser.add_argument(
        "--only", action="append", choices=BENCHMARKS, help="run only this benchmark (repeatable)"
    )
    parser.add_argument("--json", type=Path, default=None, help="also write the results as JSON")


def machine_description() -> dict[str, Any]:
    """CPU model, logical cores and library versions of this machine."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "cpu": model,
        "logical_cores": cores,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
    }


def _measure(call: Callable[[], Any], repeats: int) -> np.ndarray:
    call()  # warm-up: caches, FFT plans, lazily built kernels
    times = np.empty(repeats)
    for r in range(repeats):
        start = time.perf_counter()
        call()
        times[r] = time.perf_counter() - start
    return 1e3 * times


def _random_belief(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    centres = rng.uniform(5.0, 35.0, size=(3, 2))
    particles = centres[rng.integers(0, 3, size=n)] + rng.normal(0.0, 3.0, size=(n, 2))
    weights = rng.gamma(1.0, size=n)
    return particles, weights / weights.sum()


def _mi_calls(repeats: int) -> dict[str, np.ndarray]:
    from infoseek.envs.sensors import BearingSensor
    from infoseek.planners.information import mutual_information_batch

    rng = np.random.default_rng(0)
    particles, weights = _random_belief(10_000, rng)
    poses = rng.uniform(0.0, 40.0, size=(64, 1, 2))
    sensor = BearingSensor(sigma=0.1)
    return {
        "mi_single_fast": _measure(
            lambda: mutual_information_batch(sensor, poses, particles, weights, method="fft"),
            repeats,
        ),
        "mi_single_general": _measure(
            lambda: mutual_information_batch(
                sensor, poses, particles, weights, method="quadrature"
            ),
            max(3, repeats // 5),
        ),
    }


def _planning_times(planner_name: str, n_agents: int, repeats: int) -> np.ndarray:
    from infoseek.envs import make
    from infoseek.experiments.policies import make_policy

    env = make("bearings_v0", n_agents=n_agents, n_particles=2000, max_cycles=repeats + 5)
    observations, infos = env.reset(seed=1)
    policy = make_policy(planner_name, env, seed=1)
    policy.act(observations, infos)  # warm-up
    times = []
    while env.agents and len(times) < repeats:
        start = time.perf_counter()
        actions = policy.act(observations, infos)
        times.append(time.perf_counter() - start)
        observations, _, _, _, infos = env.step(actions)
    env.close()
    return 1e3 * np.asarray(times)


def _env_step_times(env_id: str, repeats: int) -> np.ndarray:
    from infoseek.envs import make

    env = make(env_id, n_agents=4, n_particles=2000, max_cycles=repeats + 5)
    env.reset(seed=2)
    for agent in env.possible_agents:
        env.action_space(agent).seed(2)
    times = []
    while env.agents and len(times) < repeats:
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        start = time.perf_counter()
        env.step(actions)
        times.append(time.perf_counter() - start)
    env.close()
    return 1e3 * np.asarray(times)


def run_timing(args: argparse.Namespace) -> int:
    """Run the selected benchmarks and print the table; returns the exit code."""
    if args.repeats < 1:
        raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
    selected = list(args.only) if args.only else list(BENCHMARKS)
    results: dict[str, np.ndarray] = {}
    if {"mi_single_fast", "mi_single_general"} & set(selected):
        results.update(_mi_calls(args.repeats))
    if "plan_single_10" in selected:
        results["plan_single_10"] = _planning_times("single", 10, args.repeats)
    if "plan_pairwise_10" in selected:
        results["plan_pairwise_10"] = _planning_times("pairwise", 10, args.repeats)
    if "env_step_bearings_4" in selected:
        results["env_step_bearings_4"] = _env_step_times("bearings_v0", args.repeats)
    if "env_step_beacon_4" in selected:
        results["env_step_beacon_4"] = _env_step_times("beacon_v0", args.repeats)

    machine = machine_description()
    print(
        f"machine: {machine['cpu']}, {machine['logical_cores']} logical cores, "
        f"Python {machine['python']}, NumPy {machine['numpy']}"
    )
    print(f"{'benchmark':<22} {'median ms':>10} {'q25 ms':>9} {'q75 ms':>9} {'calls':>6}")
    rows = {}
    for name in BENCHMARKS:
        if name not in results or name not in selected:
            continue
        times = results[name]
        q25, median, q75 = np.percentile(times, [25, 50, 75])
        rows[name] = {"median_ms": median, "q25_ms": q25, "q75_ms": q75, "calls": len(times)}
        print(f"{name:<22} {median:>10.2f} {q25:>9.2f} {q75:>9.2f} {len(times):>6}")
    if "mi_single_fast" in rows and "mi_single_general" in rows:
        ratio = rows["mi_single_general"]["median_ms"] / rows["mi_single_fast"]["median_ms"]
        rows["general_over_fast"] = {"ratio": ratio}
        print(f"general path / fast path: {ratio:.1f}x")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"machine": machine, "results": rows}, indent=2))
    return 0
