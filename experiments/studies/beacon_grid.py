"""The beacon's particle filter against the exact 3-D posterior on stored beacon episodes
(``infoseek reproduce beacon_grid``).

The beacon studies read their metric, agent 0's time to localise, from its particle filter
(the first step at which its mass within the localisation radius of its MMSE position reaches
0.9). This study measures the filter's own part in it. For trials ``0..K-1`` of the asked groups
``(planner, n_v)`` of a beacon store (``experiments/results/beacon/store`` by default; any
store of an environment with an ``(x, y, psi)`` static target, e.g. of a later beacon version,
with ``--store`` and ``--group``), it reruns the stored episode (the trial's spec from the
store's manifest and the harness's seeds, :class:`~infoseek.experiments.bench.BenchPlan`) and
keeps beside the environment an
:class:`~infoseek.envs.oriented_grid_posterior.OrientedGridPosterior` fed exactly the
measurements agent 0 received (its row of the reception matrix, the poses after the step, the
filters' likelihood ``config.filter_sensor``, floor included). Per step it records agent 0's
filter mass within the radius of its MMSE and that MMSE's error to the truth (as the trial
record does), the grid's mass within the radius of the grid's MMSE, the grid MMSE's position
error and its orientation error (axial); the times to localise follow
(:func:`~infoseek.experiments.analysis.time_to_localise`, censored at the episode length).

The planners read the filter's beliefs, so the flight is the stored one: the rerun's filter
masses (and errors, where the store has them) must equal the stored record's bit for bit (in
the store's float32), which proves the episode is the stored one; a trial that does not is an
error, not a result. The grid also records whether the cell holding the true target was still
active (not pruned) at the end.

The resolution check (``--halved-cells``) reruns trials with every cell of the grid halved
(eight times the cells) into ``OUT/beacon_grid_halved.json``; the page compares them.

Results: ``OUT/beacon_grid.json`` (:func:`write_results`): the provenance (command, store and
its configuration, groups, grid, machine, numerics, total wall time), then one line per trial.
A later run into the same directory with the same store configuration and grid keeps the
trials the file holds and runs only the others (e.g. another ``--group``). JSON, as
:mod:`~infoseek.experiments.studies.grid_posterior`: a few dozen trials read whole by the
results page.

Cost: the grid's likelihood pass is about ``4e-8`` s per cell and reading, so a ``beacon_v0``
episode (four readings a step, 40 steps, 400 x 400 x 64 cells pruned as the posterior
concentrates) costs 15-50 s of grid besides the planner's own time; the halved grid eight times
that.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from infoseek.envs.grid_posterior import DEFAULT_CELLS
from infoseek.envs.oriented_grid_posterior import DEFAULT_ORIENTATION_CELLS, OrientedGridPosterior
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
from infoseek.experiments.store import read_manifest
from infoseek.experiments.stored_trials import stored_trial_specs
from infoseek.experiments.trial import TrialSpec, position_metrics

__all__ = [
    "BEACON_STORE",
    "DEFAULT_GROUPS",
    "DEFAULT_TRIALS",
    "HALVED_FILE",
    "PRUNE",
    "RESULTS_FILE",
    "BeaconGridTrial",
    "GridSettings",
    "beacon_grid_specs",
    "parse_group",
    "read_results",
    "reproduce_beacon_grid",
    "run_beacon_grid_trial",
    "write_results",
]

#: The store the study reruns by default (the committed beacon store, from the checkout's root).
BEACON_STORE = Path("experiments/results/beacon/store")
#: The groups ``(planner, n_v)`` rerun by default.
DEFAULT_GROUPS: tuple[tuple[str, int], ...] = (("pairwise", 4),)
#: Trials per group.
DEFAULT_TRIALS = 30
#: The grid's pruning gap (nats; module docstring of the grid: dropped mass < 1e-14).
PRUNE = 50.0
#: The results file in the study's directory.
RESULTS_FILE = "beacon_grid.json"
#: The resolution check's results file (every cell halved: ``--halved-cells``).
HALVED_FILE = "beacon_grid_halved.json"


@dataclass(frozen=True)
class GridSettings:
    """The grid of a run.

    Attributes:
        cells: Position cells per axis.
        orientation_cells: Orientation cells over the grid's period.
        prune: Pruning gap (nats).
    """

    cells: int = DEFAULT_CELLS
    orientation_cells: int = DEFAULT_ORIENTATION_CELLS
    prune: float = PRUNE

    def halved(self) -> GridSettings:
        """The same grid with every cell halved along every axis (8 times the cells)."""
        return GridSettings(2 * self.cells, 2 * self.orientation_cells, self.prune)


@dataclass(frozen=True)
class BeaconGridTrial:
    """One rerun trial: agent 0's filter against the exact grid posterior.

    Attributes:
        planner: Planner label.
        n_agents: Number of vehicles.
        trial: Trial index.
        env_seed: The environment's seed.
        policy_seed: The policy's seed.
        truth: The true target ``(x, y, psi)``.
        filter_mass: Per step ``0..T``: agent 0's filter mass within the radius of its MMSE.
        filter_error: Per step: distance of the filter's MMSE position from the target.
        grid_mass: Per step: the grid's mass within the radius of its MMSE position.
        grid_error: Per step: distance of the grid's MMSE position from the target.
        grid_psi_error: Per step: the grid orientation estimate's axial error (``[0, pi/2]``).
        filter_ttl: The filter's time to localise (censored at ``T``).
        grid_ttl: The grid's time to localise (censored at ``T``).
        truth_active: Whether the grid cell of the true target was still active at the end.
        wall_time: Seconds the rerun took (environment, planner and grid).
    """

    planner: str
    n_agents: int
    trial: int
    env_seed: int
    policy_seed: int
    truth: tuple[float, ...]
    filter_mass: tuple[float, ...]
    filter_error: tuple[float, ...]
    grid_mass: tuple[float, ...]
    grid_error: tuple[float, ...]
    grid_psi_error: tuple[float, ...]
    filter_ttl: int
    grid_ttl: int
    truth_active: bool
    wall_time: float


def parse_group(text: str) -> tuple[str, int]:
    """``"planner/n"`` as ``(planner, n)``.

    Raises:
        ValueError: Not of that form.
    """
    planner, _, count = text.partition("/")
    if not planner or not count.isdigit() or int(count) < 1:
        raise ValueError(f"a group is PLANNER/N_AGENTS, e.g. pairwise/4; got {text!r}")
    return planner, int(count)


def beacon_grid_specs(
    store: str | os.PathLike[str], groups: Sequence[tuple[str, int]], trials: int
) -> Iterator[tuple[TrialSpec, TrialView]]:
    """The spec of trial ``0..trials-1`` of every group, with its stored view
    (:func:`~infoseek.experiments.stored_trials.stored_trial_specs`).

    Raises:
        ValueError: ``trials`` below 1, no group, or a group holds fewer trials than asked for.
    """
    if not groups:
        raise ValueError("groups: at least one (planner, n_agents)")
    return stored_trial_specs(store, groups, trials)


def run_beacon_grid_trial(
    spec: TrialSpec,
    stored_mass: Sequence[float],
    stored_error: Sequence[float] | None,
    grid: GridSettings,
) -> BeaconGridTrial:
    """Rerun one stored trial with a grid posterior beside agent 0 (module docstring), with one
    BLAS thread as :func:`~infoseek.experiments.trial.run_trial`.

    Raises:
        RuntimeError: The rerun's filter masses or errors differ from the stored ones.
    """
    started = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        env = make_env(spec.env, n_agents=spec.n_agents, max_cycles=spec.steps, **spec.env_kwargs)
        try:
            series, truth, truth_active = _episode(env, spec, grid)
        finally:
            env.close()
    wall = time.perf_counter() - started
    _check_stored(spec, series["filter_mass"], stored_mass, "masses")
    if stored_error is not None:
        _check_stored(spec, series["filter_error"], stored_error, "errors")
    steps = float(spec.steps)
    return BeaconGridTrial(
        planner=spec.planner,
        n_agents=spec.n_agents,
        trial=spec.trial,
        env_seed=spec.env_seed,
        policy_seed=spec.policy_seed,
        truth=truth,
        filter_mass=_shortest(series["filter_mass"]),
        filter_error=_shortest(series["filter_error"]),
        grid_mass=tuple(round(m, 6) for m in series["grid_mass"]),
        grid_error=tuple(round(e, 4) for e in series["grid_error"]),
        grid_psi_error=tuple(round(e, 4) for e in series["grid_psi_error"]),
        filter_ttl=int(censored_time_to_localise(series["filter_mass"], steps)),
        grid_ttl=int(censored_time_to_localise(series["grid_mass"], steps)),
        truth_active=truth_active,
        wall_time=round(wall, 1),
    )


def _check_stored(
    spec: TrialSpec, rerun: Sequence[float], stored: Sequence[float], what: str
) -> None:
    """A ``RuntimeError`` unless ``rerun`` equals ``stored`` in float32 (NaN equal to NaN)."""
    values = np.asarray(stored, dtype=np.float32)
    if not np.array_equal(np.asarray(rerun, dtype=np.float32), values, equal_nan=True):
        raise RuntimeError(f"{spec.describe()}: the rerun's filter {what} differ from the store")


def _shortest(values: Sequence[float]) -> tuple[float, ...]:
    """The float32 values' shortest decimal digits (as the store holds them)."""
    return tuple(float(str(v)) for v in np.asarray(values, dtype=np.float32))


def _axial_error(estimate: float, truth: float) -> float:
    """Distance of two angles modulo ``pi``, in ``[0, pi/2]``."""
    gap = (estimate - truth) % math.pi
    return float(min(gap, math.pi - gap))


def _episode(
    env: Any, spec: TrialSpec, settings: GridSettings
) -> tuple[dict[str, list[float]], tuple[float, ...], bool]:
    """The episode of ``spec`` (as :func:`~infoseek.experiments.trial.run_trial` steps it):
    the per-step series, the truth and whether its grid cell stayed active."""
    observations, infos = env.reset(seed=spec.env_seed)
    policy = build_policy(
        spec.planner, env, spec.policy_seed, spec.planner_options, spec.model_file
    )
    unwrapped = env.unwrapped
    config = unwrapped.config
    radius = float(config.localization_radius)
    agent = env.possible_agents[0]
    truth = np.asarray(unwrapped.true_target(), dtype=float)
    grid = OrientedGridPosterior.from_config(
        config,
        cells=settings.cells,
        orientation_cells=settings.orientation_cells,
        prune=settings.prune,
    )
    series: dict[str, list[float]] = {
        name: []
        for name in ("filter_mass", "filter_error", "grid_mass", "grid_error", "grid_psi_error")
    }

    def record() -> None:
        mass, error = position_metrics(unwrapped.belief(agent), truth[:2], radius)
        series["filter_mass"].append(mass)
        series["filter_error"].append(error)
        estimate = grid.mmse()
        series["grid_mass"].append(grid.mass_within(radius, estimate[:2]))
        series["grid_error"].append(float(np.hypot(*(estimate[:2] - truth[:2]))))
        series["grid_psi_error"].append(_axial_error(float(estimate[2]), float(truth[2])))

    record()
    for _ in range(spec.steps):
        if not env.agents:
            break
        observations, _, _, _, infos = env.step(policy.act(observations, infos))
        poses = config.vehicle.position(unwrapped.vehicle_states)
        received = unwrapped.last_reception[0]
        grid.update(config.filter_sensor, poses, unwrapped.last_measurements, received)
        record()
    truth_active = bool(np.isfinite(grid.log_posterior[grid.cell_of(truth)]))
    return series, tuple(float(v) for v in truth), truth_active


def run_beacon_grid_trials(
    store: str | os.PathLike[str],
    groups: Sequence[tuple[str, int]],
    trials: int,
    grid: GridSettings,
    workers: int = 1,
    done: Sequence[BeaconGridTrial] = (),
) -> list[BeaconGridTrial]:
    """Rerun trial ``0..trials-1`` of every group with a grid posterior beside agent 0, printing
    one line per trial.

    Args:
        store: The beacon store.
        groups: ``(planner, n_agents)`` groups the store holds.
        trials: Trials per group.
        grid: The grid.
        workers: Worker processes (``spawn``-ed, one BLAS thread each; 1: in this process).
        done: Trials already run (of the same store and grid): not rerun.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    skip = {(t.planner, t.n_agents, t.trial) for t in done}
    jobs = [
        (spec, tuple(view.mass_agent0), _errors(view), grid)
        for spec, view in beacon_grid_specs(store, groups, trials)
        if (spec.planner, spec.n_agents, spec.trial) not in skip
    ]
    if workers == 1:
        results = []
        for job in jobs:
            results.append(run_beacon_grid_trial(*job))
            _print_trial(results[-1])
        return results
    with spawn_pool(workers) as pool:
        results = list(pool.map(run_beacon_grid_trial, *zip(*jobs, strict=True), chunksize=1))
    for result in results:
        _print_trial(result)
    return results


def _errors(view: TrialView) -> tuple[float, ...] | None:
    return None if view.error_agent0 is None else tuple(view.error_agent0)


def _print_trial(trial: BeaconGridTrial) -> None:
    print(
        f"{trial.planner}/{trial.n_agents} trial {trial.trial}: time to localise filter "
        f"{trial.filter_ttl}, grid {trial.grid_ttl} ({trial.wall_time:g} s)",
        flush=True,
    )


def write_results(
    out: str | os.PathLike[str],
    results: Sequence[BeaconGridTrial],
    provenance: dict[str, Any],
    name: str = RESULTS_FILE,
) -> Path:
    """Write ``OUT/NAME``: the provenance, then one line per trial; returns the path."""
    return write_record_file(Path(out) / name, results, provenance)


def read_results(
    directory: str | os.PathLike[str], name: str = RESULTS_FILE
) -> tuple[list[BeaconGridTrial], dict[str, Any]]:
    """The trials and provenance of ``DIRECTORY/NAME``.

    Raises:
        ValueError: No results file there.
    """
    rows, provenance = read_record_file(Path(directory) / name, "beacon grid results")
    return [_trial_of(row) for row in rows], provenance


_SERIES = ("truth", "filter_mass", "filter_error", "grid_mass", "grid_error", "grid_psi_error")


def _trial_of(row: dict[str, Any]) -> BeaconGridTrial:
    """A :class:`BeaconGridTrial` from its JSON object."""
    series = {name: tuple(float(v) for v in row[name]) for name in _SERIES}
    return BeaconGridTrial(
        planner=str(row["planner"]),
        n_agents=int(row["n_agents"]),
        trial=int(row["trial"]),
        env_seed=int(row["env_seed"]),
        policy_seed=int(row["policy_seed"]),
        filter_ttl=int(row["filter_ttl"]),
        grid_ttl=int(row["grid_ttl"]),
        truth_active=bool(row["truth_active"]),
        wall_time=float(row["wall_time"]),
        **series,
    )


def provenance(
    command: str,
    store: str | os.PathLike[str],
    groups: Sequence[tuple[str, int]],
    grid: GridSettings,
    workers: int,
    wall_time: float,
) -> dict[str, Any]:
    """What the results file records of its run (the store's run configuration included)."""
    details = {"groups": [f"{p}/{n}" for p, n in groups], "grid": asdict(grid)}
    return rerun_provenance(command, store, workers, wall_time, details)


def reproduce_beacon_grid(
    out: str | os.PathLike[str],
    *,
    trials: int | None = None,
    workers: int = 1,
    store: str | os.PathLike[str] = BEACON_STORE,
    groups: Sequence[tuple[str, int]] = DEFAULT_GROUPS,
    grid: GridSettings | None = None,
    halved: bool = False,
    command: str = "",
) -> Path:
    """``infoseek reproduce beacon_grid``: rerun the trials, print the two times to localise
    per group, write the results file; returns its path. With ``halved`` (the resolution
    check) every cell of the grid is halved and the results go to :data:`HALVED_FILE`. Trials
    that the results file already holds for the same store configuration and grid are kept,
    not rerun (the file then holds the asked trials only; its wall time adds up the runs).

    Args:
        out: The study's directory.
        trials: Trials per group (default :data:`DEFAULT_TRIALS`).
        workers: Worker processes.
        store: The beacon store.
        groups: ``(planner, n_agents)`` groups.
        grid: The grid (default :class:`GridSettings`).
        halved: Run the resolution check instead (``grid`` with every cell halved).
        command: The command line, for the provenance.

    Raises:
        ValueError: No store at ``store``, or it lacks the trials asked for (nothing is run).
    """
    trials = DEFAULT_TRIALS if trials is None else trials
    grid = GridSettings() if grid is None else grid
    grid = grid.halved() if halved else grid
    if not (Path(store) / "manifest.json").is_file():
        raise ValueError(f"no store at {store} (run from the checkout's root)")
    keys = {(s.planner, s.n_agents, s.trial) for s, _ in beacon_grid_specs(store, groups, trials)}
    name = HALVED_FILE if halved else RESULTS_FILE
    done, earlier = _resumable(out, name, store, grid)
    done = [t for t in done if (t.planner, t.n_agents, t.trial) in keys]
    started = time.perf_counter()
    fresh = run_beacon_grid_trials(store, groups, trials, grid, workers, done)
    wall = time.perf_counter() - started + earlier
    order = {key: index for index, key in enumerate(sorted(keys, key=_group_order(groups)))}
    results = sorted([*done, *fresh], key=lambda t: order[(t.planner, t.n_agents, t.trial)])
    for planner, n in groups:
        group = [r for r in results if (r.planner, r.n_agents) == (planner, n)]
        filt = np.mean([r.filter_ttl for r in group])
        exact = np.mean([r.grid_ttl for r in group])
        print(
            f"{planner}/{n}: {len(group)} trials, mean time to localise filter {filt:.2f}, "
            f"grid {exact:.2f}"
        )
    record = provenance(command, store, groups, grid, workers, wall)
    return write_results(out, results, record, name)


def _group_order(groups: Sequence[tuple[str, int]]) -> Any:
    """Sort key of ``(planner, n_agents, trial)``: the groups' order, then the trial."""
    rank = {group: index for index, group in enumerate(groups)}
    return lambda key: (rank[(key[0], key[1])], key[2])


def _resumable(
    out: str | os.PathLike[str], name: str, store: str | os.PathLike[str], grid: GridSettings
) -> tuple[list[BeaconGridTrial], float]:
    """The trials of an earlier ``OUT/NAME`` of the same store (configuration) and grid, and
    its wall time (nothing if there is none or it differs: it is then rewritten)."""
    if not (Path(out) / name).is_file():
        return [], 0.0
    trials, earlier = read_results(out, name)
    same = earlier["config"] == read_manifest(store)["config"] and earlier["grid"] == asdict(grid)
    return (trials, float(earlier["wall_time"])) if same else ([], 0.0)
