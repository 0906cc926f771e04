"""One benchmark trial: an episode run by one policy, measured step by step.

:class:`TrialSpec` says everything a worker needs (picklable); :func:`run_trial` runs it and
returns its :class:`~infoseek.experiments.record.TrialRecord` (the metrics are defined there).
A trial is a pure function of its spec: a rerun (``infoseek verify``, a retry after a worker
died) gives the same record, timing fields aside.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from infoseek.experiments.environments import make_env
from infoseek.experiments.policies import build_policy
from infoseek.experiments.record import TrialRecord, trial_key

__all__ = ["TrialSpec", "run_trial"]


@dataclass(frozen=True)
class TrialSpec:
    """Everything a worker needs to run one trial (picklable).

    Attributes:
        env: Environment id or ``"module:callable"``.
        env_kwargs: Keyword arguments of the environment (without ``n_agents``,
            ``max_cycles``).
        steps: Episode length.
        planner: Planner label.
        n_agents: Number of vehicles.
        trial: Trial index.
        env_seed: Seed of ``env.reset``.
        policy_seed: Seed of the policy.
        planner_options: Keyword arguments of the planner's ``from_env``.
        model_file: Absolute path of the model of a policy label (``None``: not a policy, or
            an absolute label).
    """

    env: str
    env_kwargs: Mapping[str, Any]
    steps: int
    planner: str
    n_agents: int
    trial: int
    env_seed: int
    policy_seed: int
    planner_options: Mapping[str, Any] = field(default_factory=dict)
    model_file: str | None = None

    @property
    def key(self) -> str:
        """The trial's store key."""
        return trial_key(self.planner, self.n_agents, self.trial)

    def describe(self) -> str:
        """``"trial KEY (env_seed=..., policy_seed=...)"``: enough to rerun it alone."""
        return f"trial {self.key} (env_seed={self.env_seed}, policy_seed={self.policy_seed})"


def position_metrics(view: Any, truth_position: np.ndarray, radius: float) -> tuple[float, float]:
    """``(mass within radius of the MMSE position, MMSE position error)`` of one belief."""
    positions = np.asarray(view.particles)[:, :2]
    weights = np.asarray(view.weights, dtype=float)
    estimate = weights @ positions / weights.sum()
    inside = np.hypot(*(positions - estimate).T) <= radius
    return float(weights[inside].sum()), float(np.hypot(*(estimate - truth_position)))


def min_separation(vehicle_states: np.ndarray) -> float | None:
    """The smallest distance between two vehicles (``None`` with one)."""
    positions = np.asarray(vehicle_states)[:, :2]
    if positions.shape[0] < 2:
        return None
    deltas = positions[:, None, :] - positions[None, :, :]
    distances = np.hypot(deltas[..., 0], deltas[..., 1])
    upper = np.triu_indices(positions.shape[0], k=1)
    return float(distances[upper].min())


class _Recorder:
    """Accumulates the per-step metrics of one episode."""

    def __init__(self, agents: Sequence[str], radius: float, beliefs: Callable[[str], Any]) -> None:
        self.agents = list(agents)
        self.radius = radius
        self.beliefs = beliefs
        self.series: dict[str, list[Any]] = {
            name: []
            for name in (
                "mass_agent0",
                "mass_team",
                "error_agent0",
                "error_team",
                "entropy_agent0",
                "entropy_team",
                "min_separation",
            )
        }
        self.recoveries = 0

    def add(self, infos: Mapping[str, Mapping[str, Any]], truth: np.ndarray) -> None:
        masses, errors, entropies = [], [], []
        for agent in self.agents:
            info = infos[agent]
            mass, error = position_metrics(self.beliefs(agent), truth[:2], self.radius)
            masses.append(mass)
            errors.append(error)
            entropies.append(float(info["entropy"]))
            self.recoveries += int(bool(info.get("belief_recovered", False)))
        s = self.series
        s["mass_agent0"].append(masses[0])
        s["mass_team"].append(float(np.mean(masses)))
        s["error_agent0"].append(errors[0])
        s["error_team"].append(float(np.mean(errors)))
        s["entropy_agent0"].append(entropies[0])
        s["entropy_team"].append(float(np.mean(entropies)))
        s["min_separation"].append(min_separation(infos[self.agents[0]]["vehicle_states"]))


def run_trial(spec: TrialSpec) -> TrialRecord:
    """Run one trial; returns its record.

    The trial runs with one BLAS thread (``threadpoolctl``) and, for a trained policy, one torch
    thread, whatever the machine: OpenBLAS sums a matrix product in another order with another
    number of threads, and the planners' decisions depend on such products, so a stored trial
    reproduces on any machine only if the thread count is fixed.
    """
    with threadpool_limits(limits=1, user_api="blas"), _one_torch_thread(spec.planner):
        return _run_trial(spec)


@contextlib.contextmanager
def _one_torch_thread(planner: str) -> Iterator[None]:
    """A trained policy's trial runs torch on one thread, like BLAS: its matrix products then
    sum in one order on every machine, and its decision latency is not that of threads
    competing for a busy machine's cores."""
    if not planner.startswith("policy:"):
        yield
        return
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def _run_trial(spec: TrialSpec) -> TrialRecord:
    started = time.perf_counter()
    env = make_env(spec.env, n_agents=spec.n_agents, max_cycles=spec.steps, **spec.env_kwargs)
    try:
        observations, infos = env.reset(seed=spec.env_seed)
        policy = build_policy(
            spec.planner, env, spec.policy_seed, spec.planner_options, spec.model_file
        )
        unwrapped = env.unwrapped
        radius = float(unwrapped.config.localization_radius)
        recorder = _Recorder(env.possible_agents, radius, unwrapped.belief)
        recorder.add(infos, np.asarray(unwrapped.true_target(), dtype=float))
        plan_time: list[float] = []
        for _ in range(spec.steps):
            if not env.agents:
                break
            tic = time.perf_counter()
            actions = policy.act(observations, infos)
            plan_time.append(time.perf_counter() - tic)
            observations, _, _, _, infos = env.step(actions)
            recorder.add(infos, np.asarray(unwrapped.true_target(), dtype=float))
        truth = np.asarray(unwrapped.true_target(), dtype=float)
    finally:
        env.close()
    return TrialRecord(
        key=spec.key,
        planner=spec.planner,
        n_agents=spec.n_agents,
        trial=spec.trial,
        env_seed=spec.env_seed,
        policy_seed=spec.policy_seed,
        radius=radius,
        n_steps=len(plan_time),
        truth=tuple(float(v) for v in truth),
        recoveries=recorder.recoveries,
        wall_time=time.perf_counter() - started,
        plan_time=tuple(plan_time),
        **{name: tuple(values) for name, values in recorder.series.items()},
    )
