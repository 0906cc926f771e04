"""Monte Carlo benchmark of search policies (``infoseek bench``): a plan, run into a store.

A *run* is defined by an environment (id and keyword arguments), an episode length ``steps``
and a root ``seed`` (the store's manifest, :mod:`infoseek.experiments.store`). Inside a run,
*groups* ``(planner, n_agents)`` each get trials ``0 .. trials - 1``. Trial ``k`` of group
``(p, n)`` is one episode of ``steps`` steps with ``n`` vehicles driven by policy ``p``
(:mod:`infoseek.experiments.trial`), seeded by the run and the trial alone
(:mod:`infoseek.experiments.seeds`), recorded as a
:class:`~infoseek.experiments.record.TrialRecord`.

:func:`run_bench` runs the trials of a :class:`BenchPlan` that the store does not hold yet on an
executor backend (:mod:`infoseek.experiments.executors`) and appends each record to the store as
soon as its trial finishes, so a stopped run resumes where it stopped. Trials are generated
lazily (:meth:`BenchPlan.iter_specs`), so memory does not grow with ``--trials``.

Trained policies. ``--policy PATH`` groups are labelled portably
(:mod:`infoseek.experiments.policy_labels`: ``policy:shipped/<name>`` for a model installed with
infoseek, else the model's path relative to the results directory), so a store resumes and
verifies from any checkout; the labels enter the keys and the policy seeds like any planner's.
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from infoseek.experiments.analysis import format_summary, summarise
from infoseek.experiments.environments import (
    check_env_id,
    default_steps,
    make_env,
    non_default_env_kwargs,
)
from infoseek.experiments.executors import execute
from infoseek.experiments.policies import build_policy, check_planner, check_policy_path
from infoseek.experiments.policy_labels import display_name, is_policy, policy_file
from infoseek.experiments.progress import progress_bar
from infoseek.experiments.record import TrialRecord
from infoseek.experiments.seeds import trial_seeds
from infoseek.experiments.store import ResultsStore, read_records
from infoseek.experiments.trial import TrialSpec

__all__ = ["BenchPlan", "BenchResult", "plan_bench", "run_bench"]

#: Environment keywords a plan sets per trial (``--agents``, ``--steps``) or always
#: (``belief_in_infos``), never through ``env_kwargs``.
RESERVED_ENV_KWARGS = ("n_agents", "max_cycles", "belief_in_infos")


def _infoseek_version() -> str:
    try:
        from importlib.metadata import version

        return version("infoseek")
    except Exception:  # pragma: no cover - not installed as a distribution
        return "unknown"


@dataclass
class BenchPlan:
    """A benchmark request: the run configuration plus the groups and trials wanted.

    Attributes:
        env: Environment id.
        env_kwargs: Environment keyword arguments (no ``n_agents`` / ``max_cycles``).
        steps: Episode length.
        seed: Root seed.
        groups: ``(planner label, n_agents)`` pairs.
        trials: Trials per group.
        planner_options: Planner keyword arguments (not part of the stored configuration,
            but of the trial: keep them fixed within one results directory).
    """

    env: str
    env_kwargs: dict[str, Any]
    steps: int
    seed: int
    groups: list[tuple[str, int]]
    trials: int
    planner_options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if isinstance(self.trials, bool) or not isinstance(self.trials, int) or self.trials < 1:
            raise ValueError(f"--trials must be a positive integer, got {self.trials!r}")
        if isinstance(self.steps, bool) or not isinstance(self.steps, int) or self.steps < 1:
            raise ValueError(f"--steps must be a positive integer, got {self.steps!r}")
        if not self.groups:
            raise ValueError("nothing to run: give at least one planner and agent count")
        for planner, n_agents in self.groups:
            if not isinstance(n_agents, int) or n_agents < 1:
                raise ValueError(f"--agents must be positive integers, got {n_agents!r}")
            check_planner(planner)
        for reserved in RESERVED_ENV_KWARGS:
            if reserved in self.env_kwargs:
                raise ValueError(
                    f"env kwarg {reserved!r} is set by the benchmark (use --agents / --steps)"
                )

    @classmethod
    def for_study(
        cls,
        env: str,
        groups: Sequence[tuple[str, int]],
        trials: int,
        steps: int | None = None,
        particles: int | None = None,
        seed: int = 0,
        settings: Mapping[str, Any] | None = None,
    ) -> BenchPlan:
        """A study's plan: ``env`` with its defaults except ``settings`` and the particles per
        belief.

        Args:
            env: Environment id.
            groups: ``(planner label, n_agents)`` pairs.
            trials: Trials per group.
            steps: Episode length (``None``: the environment's).
            particles: Particles per belief (``None``: the environment's).
            seed: Root seed.
            settings: Further environment keywords (e.g. ``beacon_v1``'s filter settings on
                ``beacon_v0``).
        """
        env_kwargs: dict[str, Any] = dict(settings or {})
        if particles is not None:
            env_kwargs["n_particles"] = particles
        return cls(
            env=env,
            env_kwargs=env_kwargs,
            steps=default_steps(env, env_kwargs) if steps is None else steps,
            seed=seed,
            groups=list(groups),
            trials=trials,
        )

    def config(self) -> dict[str, Any]:
        """The stored run configuration (the manifest's ``config``): environment keywords
        equal to the environment's defaults are left out, so ``--particles 2000`` (the default
        spelled out) is the same configuration as no ``--particles``."""
        return {
            "env": self.env,
            "env_kwargs": non_default_env_kwargs(self.env, self.env_kwargs),
            "steps": self.steps,
            "seed": self.seed,
            "version": _infoseek_version(),
        }

    def model_files(self, store: str | os.PathLike[str] | None) -> dict[str, str]:
        """The model file of every policy label of the plan, resolved against the results
        directory ``store`` (``None``: the current directory)."""
        root = store if store is not None else "."
        return {
            planner: str(policy_file(planner, root))
            for planner, _ in self.groups
            if is_policy(planner)
        }

    def validate(self, store: str | os.PathLike[str] | None = None) -> None:
        """Build every group's environment and policy once, without running anything.

        Args:
            store: The results directory (policy labels are relative to it).

        Raises:
            ValueError / TypeError: An environment keyword, planner or planner/fleet-size
                combination that a trial would reject (so nothing is written for a run that
                would fail).
        """
        files = self.model_files(store)
        for n_agents in sorted({n for _, n in self.groups}):
            env = make_env(self.env, n_agents=n_agents, max_cycles=self.steps, **self.env_kwargs)
            try:
                for planner, n in self.groups:
                    if n != n_agents:
                        continue
                    try:
                        build_policy(planner, env, 0, self.planner_options, files.get(planner))
                    except (ValueError, TypeError) as error:
                        label = display_name(planner)
                        raise ValueError(f"{label} with {n_agents} agent(s): {error}") from None
            finally:
                env.close()

    def iter_specs(self, store: str | os.PathLike[str] | None = None) -> Iterator[TrialSpec]:
        """Every trial of the plan, group by group, in trial order, generated one at a time
        (a plan of 10^9 trials costs no memory).

        Args:
            store: The results directory (policy labels are relative to it).
        """
        files = self.model_files(store)
        env_kwargs = dict(self.env_kwargs)
        options = dict(self.planner_options)
        for planner, n_agents in self.groups:
            for trial in range(self.trials):
                env_seed, policy_seed = trial_seeds(self.seed, self.env, planner, n_agents, trial)
                yield TrialSpec(
                    env=self.env,
                    env_kwargs=env_kwargs,
                    steps=self.steps,
                    planner=planner,
                    n_agents=n_agents,
                    trial=trial,
                    env_seed=env_seed,
                    policy_seed=policy_seed,
                    planner_options=options,
                    model_file=files.get(planner),
                )

    def specs(self, store: str | os.PathLike[str] | None = None) -> list[TrialSpec]:
        """Every trial of the plan as a list (:meth:`iter_specs`; for small plans)."""
        return list(self.iter_specs(store))

    def wants(self, planner: str, n_agents: int, trial: int) -> bool:
        """Whether the plan asks for trial ``trial`` of group ``(planner, n_agents)``."""
        return (planner, n_agents) in self.groups and 0 <= trial < self.trials


def plan_bench(
    env: str,
    env_kwargs: dict[str, Any],
    *,
    planners: Sequence[str],
    policies: Sequence[str],
    agents: Sequence[int],
    trials: int,
    steps: int | None,
    seed: int,
    out: str | os.PathLike[str],
) -> BenchPlan:
    """The plan of an ``infoseek bench`` command, every part checked before anything runs.

    Args:
        env: Environment id or factory.
        env_kwargs: Environment keywords.
        planners: Scripted planner names or factories (duplicates dropped).
        policies: Trained-policy model paths (labelled portably for the store ``out``).
        agents: Fleet sizes (every planner runs at every size).
        trials: Trials per group.
        steps: Episode length (``None``: the environment's own).
        seed: Root seed.
        out: The results directory.
    """
    check_env_id(env)
    labels = list(dict.fromkeys(planners))
    for planner in labels:
        check_planner(planner)
    labels += [check_policy_path(path, out) for path in policies]
    sizes = sorted(set(agents))
    if any(n < 1 for n in sizes):
        raise ValueError(f"--agents must be >= 1, got {sizes}")
    return BenchPlan(
        env=env,
        env_kwargs=env_kwargs,
        steps=steps if steps is not None else default_steps(env, env_kwargs),
        seed=seed,
        groups=[(label, n) for label in labels for n in sizes],
        trials=trials,
    )


@dataclass
class BenchResult:
    """Outcome of :func:`run_bench`.

    Attributes:
        records: Stored records of the requested trials (stored before or by this call).
        ran: Number of trials run by this call.
        skipped: Number of requested trials found already stored.
        wall_time: Seconds this call took.
    """

    records: list[TrialRecord]
    ran: int
    skipped: int
    wall_time: float = 0.0

    def summary(self, steps: int) -> str:
        """The summary table of the records (:func:`~infoseek.experiments.analysis.summarise`)."""
        return format_summary(summarise(self.records, steps), steps)


def run_bench(
    plan: BenchPlan,
    out: str | os.PathLike[str],
    *,
    backend: str = "serial",
    workers: int = 1,
    address: str | None = None,
    progress: bool | None = None,
) -> BenchResult:
    """Run the missing trials of ``plan``, appending each to the store in ``out`` at once.

    Args:
        plan: What to run.
        out: Results directory (created, or resumed if it holds the same configuration).
        backend: ``"serial"``, ``"process"``, ``"ray"`` or ``"module:factory"``
            (:mod:`infoseek.experiments.executors`).
        workers: Parallel workers (process pool size / local Ray CPUs / ``max_workers``).
        address: Address of an existing Ray cluster (ray backend only).
        progress: Show a tqdm bar (``None``: only on a terminal).

    Returns:
        The stored records of the requested trials, and how many ran now.

    Raises:
        StoreConfigError: ``out`` holds another configuration (nothing is written).
        TrialFailedError: A trial raised; every trial finished before it is stored.
    """
    started = time.perf_counter()
    plan.validate(out)  # before the store is created or opened
    total = len(plan.groups) * plan.trials
    with ResultsStore(out, plan.config()) as store:
        skipped = sum(1 for key in store.keys if _planned(plan, key))
        missing = (spec for spec in plan.iter_specs(out) if spec.key not in store)
        bar = progress_bar(total, f"bench {plan.env}", progress, initial=skipped)
        ran = 0
        try:
            for _, record in execute(missing, backend=backend, workers=workers, address=address):
                if store.append(record.to_row()):
                    ran += 1
                bar.update(1)
        finally:
            bar.close()
            if ran:
                store.record_run(_run_summary(backend, workers, ran, started))
    stored = read_records(out)  # float32 series
    records = [r for r in stored if plan.wants(r.planner, r.n_agents, r.trial)]
    return BenchResult(
        records=records, ran=ran, skipped=skipped, wall_time=time.perf_counter() - started
    )


def _run_summary(backend: str, workers: int, ran: int, started: float) -> dict[str, Any]:
    """What the manifest records of one run that stored trials (machine and wall time)."""
    from infoseek.experiments.machine import describe_machine

    return {
        "trials": ran,
        "wall_time": round(time.perf_counter() - started, 3),
        "backend": backend,
        "workers": workers,
        "machine": describe_machine(),
        "version": _infoseek_version(),
    }


_KEY = re.compile(r"^(?P<planner>.+)/agents=(?P<n>\d+)/trial=(?P<trial>\d+)$")


def _planned(plan: BenchPlan, key: str) -> bool:
    """Whether the stored trial ``key`` is one the plan asks for."""
    match = _KEY.match(key)
    return match is not None and plan.wants(match["planner"], int(match["n"]), int(match["trial"]))
