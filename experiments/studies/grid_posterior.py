"""The particle filter against the exact posterior on the Fig. 1 episodes
(``infoseek reproduce grid_posterior``).

Fig. 1's metric, agent 0's time to localise, is read from its particle filter: the first step
at which the filter's posterior mass within the localisation radius of its MMSE estimate reaches
0.9. How much of it is the filter's own error? For trial ``k`` of the groups ``(planner, 4)``
of the Fig. 1 store, this study reruns the stored episode (the trial's spec from the store's
manifest and the harness's seeds, :class:`~infoseek.experiments.bench.BenchPlan`) and keeps,
beside the environment, a :class:`~infoseek.envs.grid_posterior.GridPosterior` fed exactly the
measurements agent 0 received (its row of the reception matrix, the poses after the step, the
filters' likelihood ``config.filter_sensor``). Per step it records agent 0's filter mass within
the radius of its MMSE (as the trial record does) and the grid's mass within the radius of the
grid's MMSE; the time to localise of each follows
(:func:`~infoseek.experiments.analysis.time_to_localise`, censored at the episode length).

The planners read the filter's beliefs, so the flight is the stored one: the rerun's filter
masses must equal the stored record's bit for bit (in the store's float32), which proves the
episode is the stored one; a trial that does not is an error, not a result.

Results: ``OUT/grid_posterior.json`` (:func:`write_results`): its provenance (command, store
and its configuration, grid, machine, numerics, wall time), then one line per trial: seeds,
truth, both mass series (the filter's as stored, in float32; the grid's rounded to 1e-6), the
grid MMSE's error by step (1e-4) and both times to localise. JSON, not a Parquet store: the
results are a few hundred trials computed in one run from a store that is itself the record,
read whole by the results page; the Parquet stores serve resumable runs of thousands of trials.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from infoseek.envs.grid_posterior import DEFAULT_CELLS, GridPosterior
from infoseek.experiments.analysis import censored_time_to_localise
from infoseek.experiments.columns import TrialView
from infoseek.experiments.environments import make_env
from infoseek.experiments.executors import spawn_pool
from infoseek.experiments.policies import build_policy
from infoseek.experiments.record_files import (
    read_record_file,
    rerun_provenance,
    write_record_file,
)
from infoseek.experiments.stored_trials import stored_trial_specs
from infoseek.experiments.trial import TrialSpec, position_metrics

__all__ = [
    "DEFAULT_TRIALS",
    "FIG1_STORE",
    "GRID_PLANNERS",
    "GridTrial",
    "N_AGENTS",
    "PRUNE",
    "RESULTS_FILE",
    "read_results",
    "reproduce_grid_posterior",
    "run_grid_trials",
    "write_results",
]

#: The planners compared (at :data:`N_AGENTS`), where the store holds them.
GRID_PLANNERS: tuple[str, ...] = ("single", "pairwise", "horizon")
N_AGENTS = 4
#: Trials per group.
DEFAULT_TRIALS = 200
#: The grid's pruning gap (nats): cells whose weight underflows float64 are dropped.
PRUNE = 700.0
#: The results file in the study's directory.
RESULTS_FILE = "grid_posterior.json"


@dataclass(frozen=True)
class GridTrial:
    """One rerun trial: agent 0's filter against the exact grid posterior.

    Attributes:
        planner: Planner label.
        n_agents: Number of vehicles.
        trial: Trial index.
        env_seed: The environment's seed.
        policy_seed: The policy's seed.
        truth: The true target ``(x, y)``.
        filter_mass: Per step ``0..T``: agent 0's filter mass within the radius of its MMSE.
        grid_mass: Per step: the grid posterior's mass within the radius of its MMSE.
        grid_error: Per step: distance of the grid's MMSE from the target.
        filter_ttl: The filter's time to localise (censored at ``T``).
        grid_ttl: The grid's time to localise (censored at ``T``).
    """

    planner: str
    n_agents: int
    trial: int
    env_seed: int
    policy_seed: int
    truth: tuple[float, ...]
    filter_mass: tuple[float, ...]
    grid_mass: tuple[float, ...]
    grid_error: tuple[float, ...]
    filter_ttl: int
    grid_ttl: int


def grid_specs(
    store: str | os.PathLike[str], planners: Sequence[str], trials: int
) -> Iterator[tuple[TrialSpec, TrialView]]:
    """The spec of trial ``0..trials-1`` of every group ``(planner, 4)`` the store holds, with
    its stored view (:func:`~infoseek.experiments.stored_trials.stored_trial_specs`).

    Raises:
        ValueError: ``trials`` below 1, or a group holds fewer trials than asked for.
    """
    groups = [(planner, N_AGENTS) for planner in planners]
    return stored_trial_specs(store, groups, trials, skip_absent=True)


def run_grid_trial(spec: TrialSpec, stored_mass: Sequence[float], cells: int) -> GridTrial:
    """Rerun one stored trial with a grid posterior beside agent 0 (module docstring), with one
    BLAS thread as :func:`~infoseek.experiments.trial.run_trial`.

    Raises:
        RuntimeError: The rerun's filter masses differ from the stored ones.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        env = make_env(spec.env, n_agents=spec.n_agents, max_cycles=spec.steps, **spec.env_kwargs)
        try:
            series = _episode(env, spec, cells)
        finally:
            env.close()
    filter_mass, grid_mass, grid_error, truth = series
    stored = np.asarray(stored_mass, dtype=np.float32)
    if not np.array_equal(np.asarray(filter_mass, dtype=np.float32), stored):
        raise RuntimeError(f"{spec.describe()}: the rerun's filter masses differ from the store")
    steps = float(spec.steps)
    return GridTrial(
        planner=spec.planner,
        n_agents=spec.n_agents,
        trial=spec.trial,
        env_seed=spec.env_seed,
        policy_seed=spec.policy_seed,
        truth=truth,
        filter_mass=tuple(float(str(m)) for m in stored),  # the float32's shortest digits
        grid_mass=tuple(round(m, 6) for m in grid_mass),
        grid_error=tuple(round(e, 4) for e in grid_error),
        filter_ttl=int(censored_time_to_localise(filter_mass, steps)),
        grid_ttl=int(censored_time_to_localise(grid_mass, steps)),
    )


def _episode(
    env: Any, spec: TrialSpec, cells: int
) -> tuple[list[float], list[float], list[float], tuple[float, ...]]:
    """The episode of ``spec`` (as :func:`~infoseek.experiments.trial.run_trial` steps it):
    agent 0's filter masses, the grid's masses and MMSE errors, and the truth."""
    observations, infos = env.reset(seed=spec.env_seed)
    policy = build_policy(
        spec.planner, env, spec.policy_seed, spec.planner_options, spec.model_file
    )
    unwrapped = env.unwrapped
    config = unwrapped.config
    radius = float(config.localization_radius)
    agent = env.possible_agents[0]
    truth = np.asarray(unwrapped.true_target(), dtype=float)[:2]
    grid = GridPosterior.from_config(config, cells=cells, prune=PRUNE)
    filter_mass: list[float] = []
    grid_mass: list[float] = []
    grid_error: list[float] = []

    def record() -> None:
        filter_mass.append(position_metrics(unwrapped.belief(agent), truth, radius)[0])
        estimate = grid.mmse()
        grid_mass.append(grid.mass_within(radius, estimate))
        grid_error.append(float(np.hypot(*(estimate - truth))))

    record()
    for _ in range(spec.steps):
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(policy.act(observations, infos))
        poses = config.vehicle.position(unwrapped.vehicle_states)
        received = unwrapped.last_reception[0]
        grid.update(config.filter_sensor, poses, unwrapped.last_measurements, received)
        record()
    return filter_mass, grid_mass, grid_error, tuple(float(v) for v in truth)


def run_grid_trials(
    store: str | os.PathLike[str],
    *,
    planners: Sequence[str] = GRID_PLANNERS,
    trials: int = DEFAULT_TRIALS,
    cells: int = DEFAULT_CELLS,
    workers: int = 1,
) -> list[GridTrial]:
    """Rerun trial ``0..trials-1`` of every stored group ``(planner, 4)`` with a grid posterior.

    Args:
        store: The Fig. 1 store.
        planners: Planner labels (those the store holds at ``n_v = 4``).
        trials: Trials per group.
        cells: Grid cells per axis.
        workers: Worker processes (``spawn``-ed, one BLAS thread each; 1: in this process).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    jobs = [
        (spec, tuple(view.mass_agent0), cells) for spec, view in grid_specs(store, planners, trials)
    ]
    if workers == 1:
        return [run_grid_trial(*job) for job in jobs]
    with spawn_pool(workers) as pool:
        return list(pool.map(run_grid_trial, *zip(*jobs, strict=True), chunksize=1))


def write_results(
    out: str | os.PathLike[str],
    results: Sequence[GridTrial],
    provenance: dict[str, Any],
) -> Path:
    """Write ``OUT/grid_posterior.json``: the provenance, then one line per trial; returns the
    path."""
    return write_record_file(Path(out) / RESULTS_FILE, results, provenance)


def read_results(directory: str | os.PathLike[str]) -> tuple[list[GridTrial], dict[str, Any]]:
    """The trials and provenance of ``DIRECTORY/grid_posterior.json``.

    Raises:
        ValueError: No results file there.
    """
    rows, provenance = read_record_file(Path(directory) / RESULTS_FILE, "grid-posterior results")
    return [_trial_of(row) for row in rows], provenance


def _trial_of(row: dict[str, Any]) -> GridTrial:
    """A :class:`GridTrial` from its JSON object."""
    series = {name: tuple(float(v) for v in row[name]) for name in _SERIES}
    return GridTrial(
        planner=str(row["planner"]),
        n_agents=int(row["n_agents"]),
        trial=int(row["trial"]),
        env_seed=int(row["env_seed"]),
        policy_seed=int(row["policy_seed"]),
        filter_ttl=int(row["filter_ttl"]),
        grid_ttl=int(row["grid_ttl"]),
        **series,
    )


_SERIES = ("truth", "filter_mass", "grid_mass", "grid_error")


def provenance(
    command: str, store: str | os.PathLike[str], cells: int, workers: int, wall_time: float
) -> dict[str, Any]:
    """What the results file records of its run (the store's run configuration included)."""
    details = {"grid": {"cells": cells, "prune": PRUNE}}
    return rerun_provenance(command, store, workers, wall_time, details)


#: The store the study reruns by default (the committed Fig. 1 store, from the checkout's root).
FIG1_STORE = Path("experiments/results/fig1/store")


def reproduce_grid_posterior(
    out: str | os.PathLike[str],
    *,
    trials: int | None = None,
    workers: int = 1,
    store: str | os.PathLike[str] = FIG1_STORE,
    command: str = "",
) -> Path:
    """``infoseek reproduce grid_posterior``: rerun the trials, print the two times to localise
    per group, write the results file; returns its path.

    Args:
        out: The study's directory.
        trials: Trials per group (default :data:`DEFAULT_TRIALS`).
        workers: Worker processes.
        store: The Fig. 1 store.
        command: The command line, for the provenance.

    Raises:
        ValueError: No store at ``store``, or it lacks the trials asked for (nothing is run).
    """
    trials = DEFAULT_TRIALS if trials is None else trials
    if not (Path(store) / "manifest.json").is_file():
        raise ValueError(f"no Fig. 1 store at {store} (run from the checkout's root)")
    list(grid_specs(store, GRID_PLANNERS, trials))  # every check before any work
    started = time.perf_counter()
    results = run_grid_trials(store, trials=trials, workers=workers)
    wall = time.perf_counter() - started
    for planner in dict.fromkeys(r.planner for r in results):
        group = [r for r in results if r.planner == planner]
        filt = np.mean([r.filter_ttl for r in group])
        grid = np.mean([r.grid_ttl for r in group])
        print(
            f"{planner}/{N_AGENTS}: {len(group)} trials, mean time to localise filter "
            f"{filt:.2f}, grid {grid:.2f}"
        )
    return write_results(out, results, provenance(command, store, DEFAULT_CELLS, workers, wall))
