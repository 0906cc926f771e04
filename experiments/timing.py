"""``infoseek timing``: speed of the hot paths, measured on the machine it runs on.

Each benchmark makes a warm-up call, then ``--repeats`` timed calls (:func:`time.perf_counter`);
the table reports the median, interquartile range and mean in milliseconds, the target where the
compiled-kernels issue (or, before it, the MI-engine issue) set one, and the machine (CPU model,
logical cores, Python, NumPy and the BLAS in use).

* ``mi_single_fast``: single-node MI (eq. 20) of 64 candidate poses, bearing sensor,
  N = 10,000 weighted particles (three random blobs), the ``fft`` estimator;
* ``mi_single_general``: the same through the general ``quadrature`` estimator (and the ratio);
* ``plan_single_10``, ``plan_pairwise_10``: one ``act`` of ``SingleNodePlanner`` /
  ``PairwiseNodePlanner`` for 10 airplanes on ``bearings_v0`` (2000 planning particles), over
  successive steps of one seeded episode after its first step;
* ``plan_single_beacon_4``, ``plan_pairwise_beacon_4``: the same for 4 quadrotors on
  ``beacon_v0`` (defaults: 2000 particles, the filters' noise floor, the ``fourier`` estimator);
* ``plan_pairwise_4``, ``plan_horizon_4``: ``PairwiseNodePlanner`` and
  ``RecedingHorizonPlanner`` (its defaults: ``H = 5``, 45 sequences, 128 planning particles)
  for 4 airplanes on ``bearings_v0``, the Fig. 1 setting (target: 1 s per decision);
  ``plan_horizon_10`` the same for 10 airplanes;
* ``plan_pairwise_4_steps_2_11``: ``PairwiseNodePlanner.act`` as the README's example uses it
  (``make("bearings_v0", n_agents=4, belief_in_infos=True)``, ``from_env(env, seed=...)``),
  steps 2 to 11 of seeded episodes, ten calls per episode;
* ``policy_act_bearings_4``, ``policy_act_beacon_4``: the shipped imitation policies'
  ``act`` (``infoseek.baselines.shipped_model``, 4 agents, ``belief_moments=True``) at steps
  2 to 11 of seeded episodes, as ``plan_pairwise_4_steps_2_11`` measures the planner;
* ``*_first_step``: the first ``act`` of an episode (uniform prior), one per seeded episode;
* ``decision_pairwise_4_uniform``: one coordinated decision of 4 bearing sensors at the uniform
  prior (N = 2000, 8 candidate positions per sensor on a circle of radius 1, eq. 22 with the
  penalty coordination, 3 Gauss-Seidel sweeps);
* ``env_step_bearings_4``, ``env_step_beacon_4``, ``env_step_beacon_v1_4``: one ``env.step``
  with 4 agents and 2000 particles each and random actions (no rendering; ``beacon_v1``'s step
  costs most when its filter's moves run, which random actions far from the beacon seldom
  trigger: the beacon study's stores record the step time along planned episodes);
* ``env_step_beacon_v1_4_planned``: one ``env.step`` of ``beacon_v1`` (4 quadrotors, 2000
  particles) along seeded episodes (seeds 300, 301, ...) steered by ``PairwiseNodePlanner``
  (its ``act`` is not timed): the first ``repeats`` steps after a warm-up step, over as many
  episodes as that takes; the step as the beacon study meets it, moves and all;
* ``vec_step_bearings_64``, ``vec_step_bearings_64_2_workers``: one ``step`` of
  ``make_vec("bearings_v0", num_envs=64)`` (256 agent slots, random actions, auto-reset), in
  this process and split over two worker processes. With ``env_step_bearings_4`` in the same
  run the table adds the agent transitions per second of each and their ratios to the
  PettingZoo environment's.

Usage: ``infoseek timing [--repeats R] [--only NAME ...] [--json PATH] [--baseline DIR
[--rounds N]]``; with ``--baseline`` the selected benchmarks run alternately in fresh processes
of this checkout and of the checkout at ``DIR`` (:mod:`infoseek.experiments.timing_ab`).
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

from infoseek.experiments.arguments import check_writable_file

#: Benchmark name -> target median in ms (None: no target): the compiled-kernels issue's where
#: it sets one (``env_step_beacon_v1_4_planned``: the beacon issue's), the MI-engine issue's
#: otherwise.
TARGETS: dict[str, float | None] = {
    "mi_single_fast": 2.0,
    "mi_single_general": None,
    "plan_single_10": 15.0,
    "plan_single_10_first_step": 45.0,
    "plan_pairwise_10": 12.0,
    "plan_pairwise_10_first_step": 60.0,
    "plan_single_beacon_4": 50.0,
    "plan_single_beacon_4_first_step": None,
    "plan_pairwise_beacon_4": 30.0,
    "plan_pairwise_beacon_4_first_step": None,
    "plan_pairwise_4": 5.0,
    "plan_pairwise_4_steps_2_11": 3.0,
    "plan_horizon_4": 150.0,
    "plan_horizon_4_first_step": 1000.0,
    "plan_horizon_10": None,
    "plan_horizon_10_first_step": None,
    "decision_pairwise_4_uniform": 5.0,
    "env_step_bearings_4": 0.7,
    "env_step_beacon_4": 2.5,
    "env_step_beacon_v1_4": None,
    "env_step_beacon_v1_4_planned": 5.0,
    "vec_step_bearings_64": None,
    "vec_step_bearings_64_2_workers": None,
    "policy_act_bearings_4": None,
    "policy_act_beacon_4": None,
}
BENCHMARKS = tuple(TARGETS)

#: (planner, env id, agents) of the planning benchmarks.
_PLANNING = {
    "plan_single_10": ("single", "bearings_v0", 10),
    "plan_pairwise_10": ("pairwise", "bearings_v0", 10),
    "plan_single_beacon_4": ("single", "beacon_v0", 4),
    "plan_pairwise_beacon_4": ("pairwise", "beacon_v0", 4),
    "plan_pairwise_4": ("pairwise", "bearings_v0", 4),
    "plan_horizon_4": ("horizon", "bearings_v0", 4),
    "plan_horizon_10": ("horizon", "bearings_v0", 10),
}


def add_timing_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek timing``."""
    parser.add_argument("--repeats", type=int, default=30, help="timed calls per benchmark")
    parser.add_argument(
        "--only", action="append", choices=BENCHMARKS, help="run only this benchmark (repeatable)"
    )
    parser.add_argument("--json", type=Path, default=None, help="also write the results as JSON")
    parser.add_argument(
        "--baseline",
        type=Path,
        default=None,
        help="a checkout of another infoseek version: run the selected benchmarks alternately "
        "in fresh processes of it and of this checkout and report the ratios",
    )
    parser.add_argument(
        "--rounds", type=int, default=3, help="alternations with --baseline (default 3)"
    )
    parser.add_argument(
        "--statistic",
        choices=("median", "mean"),
        default="median",
        help="with --baseline: the statistic of each process's calls that is compared (mean: "
        "what a step costs on average, rare expensive calls included)",
    )


def machine_description() -> dict[str, Any]:
    """CPU model, logical cores, library versions and the BLAS of this machine."""
    from infoseek.envs import heap

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
        "blas": _blas_description(),
        "heap_tuning": heap.tuned(),
        "platform": platform.platform(),
    }


def _blas_description() -> str:
    """The BLAS NumPy uses and its kernel, as NumPy reports them."""
    try:
        config = np.show_config(mode="dicts")  # type: ignore[call-arg]
        blas = config.get("Build Dependencies", {}).get("blas", {})
        return f"{blas.get('name', '?')} {blas.get('version', '')}".strip()
    except Exception:  # older NumPy without mode="dicts"
        return "unknown"


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


def _mi_calls(repeats: int, selected: set[str]) -> dict[str, np.ndarray]:
    from infoseek.envs.sensors import BearingSensor
    from infoseek.planners.information import mutual_information_batch

    rng = np.random.default_rng(0)
    particles, weights = _random_belief(10_000, rng)
    poses = rng.uniform(0.0, 40.0, size=(64, 1, 2))
    sensor = BearingSensor(sigma=0.1)
    results = {}
    if "mi_single_fast" in selected:
        results["mi_single_fast"] = _measure(
            lambda: mutual_information_batch(sensor, poses, particles, weights, method="fft"),
            repeats,
        )
    if "mi_single_general" in selected:
        results["mi_single_general"] = _measure(
            lambda: mutual_information_batch(
                sensor, poses, particles, weights, method="quadrature"
            ),
            max(3, repeats // 5),
        )
    return results


def _planning_times(planner_name: str, env_id: str, n_agents: int, repeats: int) -> np.ndarray:
    """Steady-state ``act`` times over successive steps of one episode (after its first)."""
    from infoseek.envs import make
    from infoseek.experiments.policies import make_policy

    env = make(
        env_id, n_agents=n_agents, n_particles=2000, max_cycles=repeats + 5, belief_in_infos=True
    )
    observations, infos = env.reset(seed=1)
    policy = make_policy(planner_name, env, seed=1)
    observations, _, _, _, infos = env.step(policy.act(observations, infos))  # first step
    times: list[float] = []
    while env.agents and len(times) < repeats:
        start = time.perf_counter()
        actions = policy.act(observations, infos)
        times.append(time.perf_counter() - start)
        observations, _, _, _, infos = env.step(actions)
    env.close()
    return 1e3 * np.asarray(times)


def _first_step_times(planner_name: str, env_id: str, n_agents: int, repeats: int) -> np.ndarray:
    """The first ``act`` of ``repeats`` seeded episodes (a fresh planner each)."""
    from infoseek.envs import make
    from infoseek.experiments.policies import make_policy

    env = make(env_id, n_agents=n_agents, n_particles=2000, max_cycles=5, belief_in_infos=True)
    times = []
    for episode in range(repeats + 1):  # episode 0 is the warm-up
        observations, infos = env.reset(seed=100 + episode)
        policy = make_policy(planner_name, env, seed=100 + episode)
        start = time.perf_counter()
        policy.act(observations, infos)
        times.append(time.perf_counter() - start)
    env.close()
    return 1e3 * np.asarray(times[1:])


def _act_times_steps_2_11(env: Any, policy_for: Callable[[int], Any], repeats: int) -> np.ndarray:
    """``act`` times (ms) at steps 2 to 11 of seeded episodes of ``env``, ten calls per
    episode, ``ceil(repeats / 10)`` episodes after a warm-up one; ``policy_for(seed)`` gives
    the policy of the episode seeded ``seed``. Closes ``env``."""
    times: list[float] = []
    for episode in range(-(-repeats // 10) + 1):  # episode 0 is the warm-up
        observations, infos = env.reset(seed=200 + episode)
        policy = policy_for(200 + episode)
        for step in range(1, 12):
            if not env.agents:
                break
            start = time.perf_counter()
            actions = policy.act(observations, infos)
            if step >= 2 and episode > 0:
                times.append(time.perf_counter() - start)
            observations, _, _, _, infos = env.step(actions)
    env.close()
    return 1e3 * np.asarray(times)


def _new_user_pairwise_times(repeats: int) -> np.ndarray:
    """``PairwiseNodePlanner.act`` at steps 2 to 11 of seeded episodes, as the README's example
    builds env and planner (a planner per episode, seeded with the episode)."""
    from infoseek.envs import make
    from infoseek.planners import PairwiseNodePlanner

    env = make("bearings_v0", n_agents=4, belief_in_infos=True)
    return _act_times_steps_2_11(
        env, lambda seed: PairwiseNodePlanner.from_env(env, seed=seed), repeats
    )


def _policy_act_times(env_id: str, model: str, repeats: int) -> np.ndarray:
    """A shipped policy's ``act`` at steps 2 to 11 of seeded episodes (one policy for all)."""
    from infoseek.baselines import load_policy, shipped_model
    from infoseek.envs import make

    env = make(env_id, n_agents=4, belief_moments=True)
    policy = load_policy(shipped_model(model), env)
    return _act_times_steps_2_11(env, lambda seed: policy, repeats)


def coordinated_decision(rng: np.random.Generator) -> Callable[[], Any]:
    """The ``decision_pairwise_4_uniform`` benchmark as a callable (see the module docstring)."""
    from infoseek.envs.sensors import BearingSensor
    from infoseek.planners.coordination import PenaltySettings, coordinate
    from infoseek.planners.information import make_estimator

    sensor = BearingSensor(sigma=0.1)
    particles = rng.uniform(0.0, 40.0, size=(2000, 2))
    weights = np.full(2000, 1.0 / 2000)
    centres = np.array([[12.0, 12.0], [28.0, 12.0], [12.0, 28.0], [28.0, 28.0]])
    angles = 2.0 * np.pi * np.arange(8) / 8
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    positions = [centre + ring for centre in centres]  # (8, 2) candidates per sensor
    controls = [np.arange(8, dtype=np.float64)[:, None]] * 4
    estimator = make_estimator("auto", sensor, n_observations=2)
    settings = PenaltySettings(min_separation=1.0, max_iterations=3)
    n_vehicles = len(centres)

    def decide() -> Any:
        belief = estimator.bind(particles, weights)
        singles = [belief.single(p) for p in positions]
        columns: list[dict[tuple[int, int], np.ndarray]] = [{} for _ in range(n_vehicles)]

        def utility(i: int, plans: np.ndarray) -> np.ndarray:
            missing = [j for j in range(n_vehicles) if j != i and (j, plans[j]) not in columns[i]]
            if missing:
                others = np.array([positions[j][plans[j]] for j in missing])
                pairs = belief.pairs(positions[i], others)
                for column, j in enumerate(missing):
                    columns[i][(j, int(plans[j]))] = pairs[:, column]
            total = (2 - n_vehicles) * singles[i]
            for j in range(n_vehicles):
                if j != i:
                    total = total + columns[i][(j, int(plans[j]))]
            return total

        return coordinate(
            controls,
            positions,
            utility,
            settings,
            initial_indices=[int(np.argmax(s)) for s in singles],
        )

    return decide


def _env_step_times(env_id: str, repeats: int) -> np.ndarray:
    from infoseek.envs import make

    env = make(env_id, n_agents=4, n_particles=2000, max_cycles=repeats + 5)
    env.reset(seed=2)
    for agent in env.possible_agents:
        env.action_space(agent).seed(2)
    times: list[float] = []
    while env.agents and len(times) < repeats:
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        start = time.perf_counter()
        env.step(actions)
        times.append(time.perf_counter() - start)
    env.close()
    return 1e3 * np.asarray(times)


def _planned_env_step_times(repeats: int) -> np.ndarray:
    """``env.step`` times (ms) of ``beacon_v1`` along whole episodes (seeds 300, 301, ...)
    steered by a pairwise-node planner seeded with the episode, until ``repeats`` steps are
    timed; the first step of the first episode is a warm-up. The planner's ``act`` is not
    timed."""
    from infoseek.envs import make
    from infoseek.planners import PairwiseNodePlanner

    env = make("beacon_v1", n_agents=4, n_particles=2000, belief_in_infos=True)
    times: list[float] = []
    seed = 300
    while len(times) < repeats + 1:
        observations, infos = env.reset(seed=seed)
        planner = PairwiseNodePlanner.from_env(env, seed=seed)
        while env.agents and len(times) < repeats + 1:
            actions = planner.act(observations, infos)
            start = time.perf_counter()
            observations, _, _, _, infos = env.step(actions)
            times.append(time.perf_counter() - start)
        seed += 1
    env.close()
    return 1e3 * np.asarray(times[1:])


def _vec_step_times(n_workers: int, repeats: int) -> np.ndarray:
    from infoseek.baselines import make_vec

    venv = make_vec("bearings_v0", num_envs=64, n_workers=n_workers)
    try:
        venv.seed(2)
        venv.reset()
        rng = np.random.default_rng(2)
        low, high = venv.action_space.low, venv.action_space.high
        venv.step(rng.uniform(low, high, size=(venv.num_envs, *venv.action_space.shape)))
        times: list[float] = []
        for _ in range(repeats):
            actions = rng.uniform(low, high, size=(venv.num_envs, *venv.action_space.shape))
            start = time.perf_counter()
            venv.step(actions)
            times.append(time.perf_counter() - start)
    finally:
        venv.close()
    return 1e3 * np.asarray(times)


def _throughputs(rows: dict[str, Any]) -> None:
    """Agent transitions per second of the env benchmarks, and the vector env's speed-ups."""
    slots = {
        "env_step_bearings_4": 4,
        "vec_step_bearings_64": 256,
        "vec_step_bearings_64_2_workers": 256,
    }
    rates = {n: k / (rows[n]["median_ms"] / 1e3) for n, k in slots.items() if n in rows}
    for name, rate in rates.items():
        line = f"{name}: {rate:,.0f} agent transitions/s"
        if name != "env_step_bearings_4" and "env_step_bearings_4" in rates:
            ratio = rate / rates["env_step_bearings_4"]
            rows[f"{name}_over_env_step"] = {"ratio": ratio}
            line += f" ({ratio:.2f}x the PettingZoo env)"
        rows[name]["agent_transitions_per_s"] = rate
        print(line)


def _run(selected: list[str], repeats: int) -> dict[str, np.ndarray]:
    results: dict[str, np.ndarray] = {}
    results.update(_mi_calls(repeats, set(selected)))
    for name, (planner, env_id, n_agents) in _PLANNING.items():
        if name in selected:
            results[name] = _planning_times(planner, env_id, n_agents, repeats)
        if f"{name}_first_step" in selected:
            results[f"{name}_first_step"] = _first_step_times(planner, env_id, n_agents, repeats)
    if "plan_pairwise_4_steps_2_11" in selected:
        results["plan_pairwise_4_steps_2_11"] = _new_user_pairwise_times(repeats)
    if "decision_pairwise_4_uniform" in selected:
        decide = coordinated_decision(np.random.default_rng(3))
        results["decision_pairwise_4_uniform"] = _measure(decide, repeats)
    for name, env_id in (
        ("env_step_bearings_4", "bearings_v0"),
        ("env_step_beacon_4", "beacon_v0"),
        ("env_step_beacon_v1_4", "beacon_v1"),
    ):
        if name in selected:
            results[name] = _env_step_times(env_id, repeats)
    if "env_step_beacon_v1_4_planned" in selected:
        results["env_step_beacon_v1_4_planned"] = _planned_env_step_times(repeats)
    for name, workers in (("vec_step_bearings_64", 1), ("vec_step_bearings_64_2_workers", 2)):
        if name in selected:
            results[name] = _vec_step_times(workers, repeats)
    for name, env_id, model in (
        ("policy_act_bearings_4", "bearings_v0", "dagger_bearings_v0_4agents"),
        ("policy_act_beacon_4", "beacon_v0", "dagger_beacon_v0_4agents"),
    ):
        if name in selected:
            results[name] = _policy_act_times(env_id, model, repeats)
    return results


def run_timing(args: argparse.Namespace) -> int:
    """Run the selected benchmarks and print the table; returns the exit code."""
    if args.repeats < 1:
        raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
    selected = list(args.only) if args.only else list(BENCHMARKS)
    if args.json is not None:
        check_writable_file(args.json, "--json")
    if args.statistic != "median" and args.baseline is None:
        raise ValueError(
            "--statistic compares --baseline runs; without --baseline the table prints both "
            "the median and the mean"
        )
    if args.baseline is not None:
        from infoseek.experiments.timing_ab import run_alternating

        return run_alternating(
            args.baseline, selected, args.repeats, args.rounds, args.json, args.statistic
        )
    results = _run(selected, args.repeats)
    machine = machine_description()
    print(
        f"machine: {machine['cpu']}, {machine['logical_cores']} logical cores, "
        f"Python {machine['python']}, NumPy {machine['numpy']}, BLAS {machine['blas']}, "
        f"heap tuning {'on' if machine['heap_tuning'] else 'off'}"
    )
    header = (
        f"{'benchmark':<34} {'median ms':>10} {'q25 ms':>9} {'q75 ms':>9} {'mean ms':>9} "
        f"{'calls':>6}"
    )
    print(f"{header} {'target ms':>10}")
    rows: dict[str, Any] = {}
    for name in BENCHMARKS:
        if name not in results:
            continue
        times = results[name]
        q25, median, q75 = np.percentile(times, [25, 50, 75])
        mean = float(np.mean(times))
        target = TARGETS[name]
        rows[name] = {
            "median_ms": median,
            "q25_ms": q25,
            "q75_ms": q75,
            "mean_ms": mean,
            "calls": len(times),
            "target_ms": target,
        }
        verdict = (
            "" if target is None else f"{target:>10g} {'met' if median <= target else 'missed'}"
        )
        print(
            f"{name:<34} {median:>10.2f} {q25:>9.2f} {q75:>9.2f} {mean:>9.2f} "
            f"{len(times):>6} {verdict}"
        )
    if "mi_single_fast" in rows and "mi_single_general" in rows:
        ratio = rows["mi_single_general"]["median_ms"] / rows["mi_single_fast"]["median_ms"]
        rows["general_over_fast"] = {"ratio": ratio}
        print(f"general path / fast path: {ratio:.1f}x")
    _throughputs(rows)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"machine": machine, "results": rows}, indent=2))
    return 0
