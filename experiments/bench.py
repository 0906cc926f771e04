"""Monte Carlo benchmark of search policies (``infoseek bench``).

A *run* is defined by an environment (id and keyword arguments), an episode length ``steps``
and a root ``seed`` (the store's manifest, :mod:`infoseek.experiments.store`). Inside a run,
*groups* ``(planner, n_agents)`` each get trials ``0 .. trials - 1``. Trial ``k`` of group
``(p, n)`` is one episode of ``steps`` steps with ``n`` vehicles driven by policy ``p``.

Seeds. Every trial's seeds are pure functions of the run and the trial, never of the backend,
worker count or completion order:

* ``env_seed = H("env", seed, env, k)`` seeds ``env.reset`` (true target, initial vehicle
  states, observation noise, belief particles). It depends on neither the planner nor the
  agent count, so every group of a run faces the same true target in trial ``k`` (the
  environments draw it from the first child stream of their seed, whatever the fleet size):
  common random numbers, so the comparisons of Fig. 1 (single- vs pairwise-node, fleet
  sizes) have less variance.
* ``policy_seed = H("policy", seed, env, planner, n_agents, k)`` seeds the policy's own
  stream.

``H`` is the first 8 bytes (little-endian) of SHA-256 of the fields' ``str`` joined by
``"|"``, masked to 63 bits.

Per-step metrics. For step ``t = 0`` (after ``reset``) through ``T`` (``T = steps`` unless the
episode ended earlier), with agent beliefs ``b_i`` (weights ``w``, positions ``x``), MMSE
position estimate ``xhat_i = sum_j w_j x_j`` (eq. 12; position coordinates are never
periodic), radius ``r = env.unwrapped.localization_radius`` (1 unit, as in Fig. 1) and true
position ``x*`` (``env.unwrapped.true_target()``, used only here, never by the policy):

* ``mass_agent0[t]`` -- ``sum_j w_j [||x_j - xhat_0|| <= r]`` of agent 0's belief: the
  probability that the target is within ``r`` of the MMSE estimate (the metric of Fig. 1);
  ``mass_team[t]`` -- its mean over the agents.
* ``error_agent0[t]`` -- ``||xhat_0 - x*||``; ``error_team[t]`` its mean over the agents.
* ``entropy_agent0[t]``, ``entropy_team[t]`` -- the env's belief entropy estimate
  (``infos[agent]["entropy"]``) of agent 0 and the team mean.
* ``min_separation[t]`` -- the smallest distance between two vehicles (``null`` with one).
* ``plan_time[t - 1]`` for ``t >= 1`` -- seconds the policy spent choosing the actions that
  led to step ``t`` (one ``act`` call for the whole team), so it has ``T`` entries.

A record also has ``key``, ``planner``, ``n_agents``, ``trial``, ``env_seed``,
``policy_seed``, ``radius``, ``n_steps`` (``T``), ``truth`` (the true target state at ``T``),
``recoveries`` (belief-degeneracy recoveries summed over agents and steps) and ``wall_time``.
Everything except the timing fields :data:`TIMING_FIELDS` is a deterministic function of the
run configuration and the trial, identical on every backend.

Time to localise. The first ``t`` with ``mass_agent0[t] >= 0.9``; a trial that never gets
there is censored at ``steps`` (the summary counts them separately).

Backends. ``serial`` runs trials in this process; ``process`` in a
:class:`concurrent.futures.ProcessPoolExecutor` (``forkserver`` context where available, else
``spawn``); ``ray`` as ``ray.remote`` tasks (an existing cluster via ``address``, else a local
Ray started for the run and shut down afterwards). In every case the parent process appends
each record to the store as soon as its trial finishes. Trials are generated lazily
(:meth:`BenchPlan.iter_specs`) and handed to the workers as they free up, at most
:data:`IN_FLIGHT_PER_WORKER` per worker ahead, so memory does not grow with ``--trials``.

Trained policies. ``--policy PATH`` groups are labelled portably
(:mod:`infoseek.experiments.policy_labels`: ``policy:shipped/<name>`` for a model installed with
infoseek, else the model's path relative to the results directory), so a store resumes and
verifies from any checkout; the labels enter the keys and the policy seeds like any planner's.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import itertools
import json
import math
import multiprocessing
import os
import re
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from infoseek.experiments.policies import PLANNER_NAMES, make_policy
from infoseek.experiments.policy_labels import (
    POLICY_PREFIX,
    display_name,
    is_policy,
    policy_file,
    portable_label,
)
from infoseek.experiments.store import ResultsStore, read_records, trial_key

#: Fields of a trial record that measure time and so differ between otherwise identical runs.
TIMING_FIELDS: frozenset[str] = frozenset({"plan_time", "wall_time"})
#: Posterior mass within the localisation radius that counts as "localised".
LOCALISED_MASS = 0.9
BACKENDS: tuple[str, ...] = ("serial", "process", "ray")
#: Trials in flight per worker on the process and ray backends (the rest are generated as
#: workers free up, so memory does not grow with the number of trials requested).
IN_FLIGHT_PER_WORKER = 2


def _infoseek_version() -> str:
    try:
        from importlib.metadata import version

        return version("infoseek")
    except Exception:  # pragma: no cover - not installed as a distribution
        return "unknown"


def derive_seed(*fields: object) -> int:
    """A 63-bit seed that is a pure function of ``fields`` (SHA-256 of their ``"|"`` join)."""
    text = "|".join(str(f) for f in fields)
    digest = hashlib.sha256(text.encode()).digest()
    return int.from_bytes(digest[:8], "little") & ((1 << 63) - 1)


def trial_seeds(seed: int, env: str, planner: str, n_agents: int, trial: int) -> tuple[int, int]:
    """``(env_seed, policy_seed)`` of one trial (see the module docstring)."""
    env_seed = derive_seed("env", seed, env, trial)
    policy_seed = derive_seed("policy", seed, env, planner, n_agents, trial)
    return env_seed, policy_seed


def _import_object(spec: str, what: str) -> Any:
    """The object named ``"package.module:attribute"`` (``attribute`` may be dotted, e.g.
    ``"mypackage.planners:MyPlanner.from_env"``)."""
    module_name, _, attribute = spec.partition(":")
    if not module_name or not attribute:
        raise ValueError(f"{what} {spec!r}: expected 'package.module:callable'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(f"{what} {spec!r}: cannot import {module_name!r} ({error})") from None
    target: Any = module
    try:
        for name in attribute.split("."):
            target = getattr(target, name)
    except AttributeError:
        raise ValueError(f"{what} {spec!r}: {module_name!r} has no {attribute!r}") from None
    return target


def env_ids() -> list[str]:
    """The registered environment ids."""
    from infoseek.envs import registry

    return sorted(registry)


def check_env_id(env: str) -> None:
    """Raise ``ValueError`` unless ``env`` is a registered id or ``"module:callable"``."""
    if ":" in env:
        if not callable(_import_object(env, "--env")):
            raise ValueError(f"--env {env!r} is not callable")
        return
    valid = env_ids()
    if env not in valid:
        raise ValueError(f"unknown environment {env!r}; expected one of {valid}")


def make_env(env: str, **kwargs: Any) -> Any:
    """Build environment ``env``: a registered id, or a ``"module:callable"`` factory.

    The environment puts every agent's belief view in its infos (``belief_in_infos``, what the
    planners read); that is not part of the stored configuration, as it changes no decision.
    """
    if ":" in env:
        built = _import_object(env, "--env")(**kwargs)
    else:
        from infoseek.envs import make

        built = make(env, **kwargs)
    if hasattr(built.unwrapped, "belief_in_infos"):
        built.unwrapped.belief_in_infos = True
    return built


def non_default_env_kwargs(env: str, env_kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` without the keywords whose value is the registered environment's
    default (all of them kept for a ``"module:callable"`` environment)."""
    if ":" in env:
        return dict(env_kwargs)
    import inspect

    from infoseek.envs import registry
    from infoseek.envs.search_env import InformationSeekingEnv

    parameters = inspect.signature(InformationSeekingEnv.__init__).parameters
    defaults = {
        name: p.default
        for name, p in parameters.items()
        if p.default is not inspect.Parameter.empty
    }
    defaults.update(registry[env].kwargs)
    missing = object()
    return {
        key: value
        for key, value in env_kwargs.items()
        if json.dumps(defaults.get(key, missing), default=repr) != json.dumps(value, default=repr)
    }


def default_steps(env: str, env_kwargs: Mapping[str, Any]) -> int:
    """The environment's own episode length (``max_cycles``) for these keyword arguments."""
    instance = make_env(env, n_agents=1, **env_kwargs)
    try:
        return int(instance.unwrapped.max_cycles)
    finally:
        instance.close()


def check_planner(planner: str) -> None:
    """Raise ``ValueError`` unless ``planner`` is a scripted planner name or a factory path."""
    if planner.startswith(POLICY_PREFIX):
        return
    if ":" in planner:
        if not callable(_import_object(planner, "--planner")):
            raise ValueError(f"--planner {planner!r} is not callable")
        return
    if planner not in PLANNER_NAMES:
        raise ValueError(f"unknown planner {planner!r}; expected one of {PLANNER_NAMES}")


def trained_policy_loader() -> Callable[..., Any]:
    """The loader of trained RL policies, ``load_policy(path, env, seed=...)``.

    It is provided by :mod:`infoseek.baselines` (``infoseek.baselines.load_policy``).

    Raises:
        ValueError: :mod:`infoseek.baselines` does not provide ``load_policy`` (yet).
    """
    try:
        import infoseek.baselines as baselines
    except ImportError as error:  # pragma: no cover - package always present
        raise ValueError(f"--policy needs infoseek.baselines ({error})") from None
    loader = getattr(baselines, "load_policy", None)
    if not callable(loader):
        raise ValueError(
            "--policy: loading trained RL policies needs infoseek.baselines.load_policy"
            "(path, env, seed=...), which this installation does not provide yet; "
            "use --planner with one of " + str(PLANNER_NAMES)
        )
    return loader


def check_policy_path(path: str, store: str | os.PathLike[str] | None = None) -> str:
    """Validate a ``--policy`` path; returns its planner label.

    Args:
        path: The model file (or run directory).
        store: The results directory the label is for: the label is then portable
            (:func:`infoseek.experiments.policy_labels.portable_label`, what ``infoseek bench``
            uses); ``None`` gives ``"policy:<absolute path>"``, valid for any store on this
            machine but not portable.
    """
    resolved = Path(path).expanduser().resolve()
    if not resolved.exists():
        raise ValueError(f"--policy {path!r}: no such file or directory")
    for module in ("torch", "stable_baselines3"):
        try:
            importlib.import_module(module)
        except ImportError:
            raise ValueError(
                f"--policy needs the RL dependencies ({module} is not installed): "
                "pip install 'infoseek[rl]'"
            ) from None
    trained_policy_loader()
    return POLICY_PREFIX + str(resolved) if store is None else portable_label(resolved, store)


def build_policy(
    planner: str,
    env: Any,
    seed: int,
    options: Mapping[str, Any],
    model_file: str | None = None,
) -> Any:
    """The policy called ``planner`` (name, ``"module:callable"`` or a policy label).

    Args:
        planner: The planner label.
        env: The environment it acts in.
        seed: Its seed.
        options: Planner options (scripted planners and factories).
        model_file: The model file of a policy label (resolved against its store); ``None``:
            the label's own path (absolute labels).
    """
    if is_policy(planner):
        path = model_file if model_file is not None else str(policy_file(planner, "."))
        return trained_policy_loader()(path, env, seed=seed)
    if ":" in planner:
        return _import_object(planner, "--planner")(env, seed=seed, **options)
    return make_policy(planner, env, seed=seed, **options)


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


def _position_metrics(view: Any, truth_position: np.ndarray, radius: float) -> tuple[float, float]:
    """``(mass within radius of the MMSE position, MMSE position error)`` of one belief."""
    positions = np.asarray(view.particles)[:, :2]
    weights = np.asarray(view.weights, dtype=float)
    estimate = weights @ positions / weights.sum()
    inside = np.hypot(*(positions - estimate).T) <= radius
    return float(weights[inside].sum()), float(np.hypot(*(estimate - truth_position)))


def _min_separation(vehicle_states: np.ndarray) -> float | None:
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
            mass, error = _position_metrics(self.beliefs(agent), truth[:2], self.radius)
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
        s["min_separation"].append(_min_separation(infos[self.agents[0]]["vehicle_states"]))


def run_trial(spec: TrialSpec) -> dict[str, Any]:
    """Run one trial; returns its record (see the module docstring for the fields).

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


def _run_trial(spec: TrialSpec) -> dict[str, Any]:
    started = time.perf_counter()
    env = make_env(spec.env, n_agents=spec.n_agents, max_cycles=spec.steps, **spec.env_kwargs)
    try:
        observations, infos = env.reset(seed=spec.env_seed)
        policy = build_policy(
            spec.planner, env, spec.policy_seed, spec.planner_options, spec.model_file
        )
        unwrapped = env.unwrapped
        radius = float(unwrapped.localization_radius)
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
    record: dict[str, Any] = {
        "key": spec.key,
        "planner": spec.planner,
        "n_agents": spec.n_agents,
        "trial": spec.trial,
        "env_seed": spec.env_seed,
        "policy_seed": spec.policy_seed,
        "radius": radius,
        "n_steps": len(plan_time),
        "truth": truth.tolist(),
        "recoveries": recorder.recoveries,
        "plan_time": plan_time,
        **recorder.series,
    }
    record["wall_time"] = time.perf_counter() - started
    return record


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
        if not isinstance(self.trials, int) or self.trials < 1:
            raise ValueError(f"--trials must be a positive integer, got {self.trials!r}")
        if not isinstance(self.steps, int) or self.steps < 1:
            raise ValueError(f"--steps must be a positive integer, got {self.steps!r}")
        if not self.groups:
            raise ValueError("nothing to run: give at least one planner and agent count")
        for planner, n_agents in self.groups:
            if not isinstance(n_agents, int) or n_agents < 1:
                raise ValueError(f"--agents must be positive integers, got {n_agents!r}")
            check_planner(planner)
        for reserved in ("n_agents", "max_cycles"):
            if reserved in self.env_kwargs:
                raise ValueError(
                    f"env kwarg {reserved!r} is set by the benchmark (use --agents / --steps)"
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

    def wants(self, record: Mapping[str, Any]) -> bool:
        """Whether the plan asks for the trial of the stored ``record``."""
        group = (str(record["planner"]), int(record["n_agents"]))
        return group in self.groups and 0 <= int(record["trial"]) < self.trials


class TrialFailedError(RuntimeError):
    """A trial raised; carries its key and seeds so it can be reproduced alone."""


def _describe(spec: TrialSpec) -> str:
    return f"trial {spec.key} (env_seed={spec.env_seed}, policy_seed={spec.policy_seed})"


def _serial(specs: Iterable[TrialSpec]) -> Iterator[tuple[TrialSpec, dict[str, Any]]]:
    for spec in specs:
        try:
            record = run_trial(spec)
        except Exception as error:
            raise TrialFailedError(f"{_describe(spec)} failed: {error!r}") from error
        yield spec, record


def _process_context() -> multiprocessing.context.BaseContext:
    """``spawn``: workers are children of this process (so :func:`_die_with_parent` ties
    them to it) and start from a clean interpreter (the pinned numerical environment)."""
    return multiprocessing.get_context("spawn")


#: Thread-count variables of the BLAS/OpenMP libraries NumPy and SciPy may use.
_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def single_threaded_workers() -> Iterator[None]:
    """Worker processes started inside this block use one BLAS thread each (unless the user
    set the variables): with one trial per core, multithreaded matrix products in every worker
    would oversubscribe the cores."""
    saved = {name: os.environ.get(name) for name in _THREAD_VARIABLES}
    for name in _THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _die_with_parent(parent: int) -> None:
    """Worker initializer: on Linux, ask the kernel to kill this worker when its parent dies
    (a killed ``bench`` then leaves no worker processes behind); a worker whose parent
    ``parent`` died before this ran (a slow start on a loaded machine) exits at once."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

        try:
            ctypes.CDLL("libc.so.6").prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # pragma: no cover - exotic libc
            pass
    if os.getppid() != parent:
        os._exit(1)


def _processes(
    specs: Iterable[TrialSpec], workers: int
) -> Iterator[tuple[TrialSpec, dict[str, Any]]]:
    """Trials on a pool of ``workers`` processes, at most :data:`IN_FLIGHT_PER_WORKER` per
    worker submitted at a time (the next spec is drawn when a trial finishes). If the caller
    stops early (Ctrl-C, a failed trial, the generator closed), the pool's workers are
    terminated: ``shutdown`` only cancels the trials not yet started, and the running ones
    would keep this process waiting at exit until they finish."""
    others = set(multiprocessing.active_children())
    finished = False
    with single_threaded_workers():
        executor = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=_process_context(),
            initializer=_die_with_parent,
            initargs=(os.getpid(),),
        )
        executor.submit(int).result()  # start the workers while the variables are set
    queue = iter(specs)
    pending: dict[Future[dict[str, Any]], TrialSpec] = {}

    def submit_next() -> None:
        spec = next(queue, None)
        if spec is not None:
            pending[executor.submit(run_trial, spec)] = spec

    try:
        for _ in range(IN_FLIGHT_PER_WORKER * workers):
            submit_next()
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                spec = pending.pop(future)
                try:
                    record = future.result()
                except Exception as error:
                    raise TrialFailedError(f"{_describe(spec)} failed: {error!r}") from error
                submit_next()
                yield spec, record
        finished = True
    finally:
        executor.shutdown(wait=False, cancel_futures=True)
        if not finished:
            _terminate(set(multiprocessing.active_children()) - others)


def _terminate(processes: Iterable[multiprocessing.process.BaseProcess]) -> None:
    """Terminate ``processes`` (SIGTERM, then SIGKILL after 5 s) and reap them."""
    processes = list(processes)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=5.0)
        if process.is_alive():
            process.kill()
            process.join()


def _ray(
    specs: Iterable[TrialSpec], workers: int, address: str | None
) -> Iterator[tuple[TrialSpec, dict[str, Any]]]:
    try:
        import ray
    except ImportError:
        raise ValueError(
            "--backend ray needs the 'ray' package (pip install infoseek[distributed])"
        ) from None
    started_here = False
    if not ray.is_initialized():
        from infoseek.experiments.numerics import PINNED

        env_vars = {key: os.environ[key] for key in PINNED if key in os.environ}
        runtime_env = {"env_vars": env_vars} if env_vars else None
        if address:
            ray.init(address=address, log_to_driver=False, runtime_env=runtime_env)
        else:
            ray.init(
                num_cpus=workers,
                include_dashboard=False,
                log_to_driver=False,
                runtime_env=runtime_env,
            )
        started_here = True
    pending: dict[Any, TrialSpec] = {}
    queue = iter(specs)
    try:
        remote_trial = ray.remote(num_cpus=1, max_retries=0)(run_trial)
        for spec in itertools.islice(queue, IN_FLIGHT_PER_WORKER * workers):
            pending[remote_trial.remote(spec)] = spec
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                spec = pending.pop(ref)
                try:
                    record = ray.get(ref)
                except Exception as error:
                    raise TrialFailedError(f"{_describe(spec)} failed: {error!r}") from error
                following = next(queue, None)
                if following is not None:
                    pending[remote_trial.remote(following)] = following
                yield spec, record
    finally:
        for ref in pending:  # interrupted or failed: drop the trials not yet finished
            ray.cancel(ref, force=True)
        if started_here:
            ray.shutdown()


def execute(
    specs: Iterable[TrialSpec],
    backend: str = "serial",
    workers: int = 1,
    address: str | None = None,
) -> Iterator[tuple[TrialSpec, dict[str, Any]]]:
    """Run ``specs`` on ``backend``; yields ``(spec, record)`` as trials finish.

    ``specs`` may be a generator: it is drawn from as workers free up (at most
    :data:`IN_FLIGHT_PER_WORKER` trials per worker are submitted ahead), never all at once.

    Raises:
        ValueError: Unknown backend, bad worker count, or ray missing.
        TrialFailedError: A trial raised (the trials already yielded are unaffected).
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of {list(BACKENDS)}")
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"--workers must be a positive integer, got {workers!r}")
    queue = iter(specs)
    first = next(queue, None)
    if first is None:  # nothing to run: start no pool
        return iter(())
    queue = itertools.chain([first], queue)
    if backend == "serial":
        return _serial(queue)
    if backend == "process":
        return _processes(queue, workers)
    return _ray(queue, workers, address)


@dataclass
class BenchResult:
    """Outcome of :func:`run_bench`.

    Attributes:
        records: Stored records of the requested trials (stored before or by this call).
        ran: Number of trials run by this call.
        skipped: Number of requested trials found already stored.
    """

    records: list[dict[str, Any]]
    ran: int
    skipped: int


def trial_progress_bar(
    total: int, desc: str, progress: bool | None, initial: int = 0, unit: str = "trial"
) -> Any:
    """A tqdm bar (count, elapsed time and the estimated time left) on stderr.

    Args:
        total: Units in all.
        desc: Label of the bar.
        progress: Show it (``None``: only on a terminal).
        initial: Units already done.
        unit: What is counted.
    """
    from tqdm import tqdm

    return tqdm(
        total=total,
        initial=initial,
        unit=unit,
        desc=desc,
        disable=(not progress) if progress is not None else None,
        file=sys.stderr,
    )


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
        backend: ``"serial"``, ``"process"`` or ``"ray"``.
        workers: Parallel workers (process pool size / local Ray CPUs).
        address: Address of an existing Ray cluster (ray backend only).
        progress: Show a tqdm bar (``None``: only on a terminal).

    Returns:
        The stored records of the requested trials, and how many ran now.

    Raises:
        StoreConfigError: ``out`` holds another configuration (nothing is written).
        TrialFailedError: A trial raised; every trial finished before it is stored.
    """
    plan.validate(out)  # before the store is created or opened
    total = len(plan.groups) * plan.trials
    with ResultsStore(out, plan.config()) as store:
        skipped = sum(1 for key in store.keys if _planned(plan, key))
        missing = (spec for spec in plan.iter_specs(out) if spec.key not in store)
        bar = trial_progress_bar(total, f"bench {plan.env}", progress, initial=skipped)
        ran = 0
        try:
            for _, record in execute(missing, backend=backend, workers=workers, address=address):
                if store.append(record):
                    ran += 1
                bar.update(1)
        finally:
            bar.close()
    records = [record for record in read_records(out) if plan.wants(record)]  # stored form
    return BenchResult(records=records, ran=ran, skipped=skipped)


_KEY = re.compile(r"^(?P<planner>.+)/agents=(?P<n>\d+)/trial=(?P<trial>\d+)$")


def _planned(plan: BenchPlan, key: str) -> bool:
    """Whether the stored trial ``key`` is one the plan asks for."""
    match = _KEY.match(key)
    return match is not None and plan.wants(
        {"planner": match["planner"], "n_agents": match["n"], "trial": match["trial"]}
    )


def time_to_localise(mass: Sequence[float | None], threshold: float = LOCALISED_MASS) -> int | None:
    """First step index whose posterior mass is ``>= threshold``; ``None`` if never."""
    for step, value in enumerate(mass):
        if value is not None and value >= threshold:
            return step
    return None


@dataclass(frozen=True)
class GroupSummary:
    """Summary of one ``(planner, n_agents)`` group (one row of the table)."""

    planner: str
    n_agents: int
    trials: int
    ttl_mean: float
    ttl_quartiles: tuple[float, float, float]
    never: int
    final_mass: float
    plan_ms: float


def summarise(
    records: Iterable[Mapping[str, Any]], steps: int, threshold: float = LOCALISED_MASS
) -> list[GroupSummary]:
    """Per-group time-to-localise (censored at ``steps``), final mass and planning time."""
    groups: dict[tuple[str, int], list[Mapping[str, Any]]] = {}
    for record in records:
        groups.setdefault((record["planner"], int(record["n_agents"])), []).append(record)
    rows = []
    for (planner, n_agents), members in sorted(groups.items()):
        times = [time_to_localise(r["mass_agent0"], threshold) for r in members]
        censored = np.array([steps if t is None else t for t in times], dtype=float)
        final = np.array([r["mass_agent0"][-1] for r in members], dtype=float)
        plan = [t for r in members for t in r["plan_time"]]
        q25, q50, q75 = np.percentile(censored, [25, 50, 75])
        rows.append(
            GroupSummary(
                planner=planner,
                n_agents=n_agents,
                trials=len(members),
                ttl_mean=float(censored.mean()),
                ttl_quartiles=(float(q25), float(q50), float(q75)),
                never=sum(t is None for t in times),
                final_mass=float(final.mean()),
                plan_ms=1e3 * float(np.mean(plan)) if plan else math.nan,
            )
        )
    return rows


def format_summary(rows: Sequence[GroupSummary], steps: int) -> str:
    """The summary table as text (planners by their whole readable name,
    :func:`~infoseek.experiments.policy_labels.display_name`)."""
    labels = [display_name(row.planner) for row in rows]
    width = max([16, *(len(label) for label in labels)])
    header = (
        f"{'planner':<{width}} {'agents':>6} {'trials':>6} {'ttl mean':>8} {'q25':>6} "
        f"{'median':>6} {'q75':>6} {'never':>5} {'final mass':>10} {'plan ms/step':>12}"
    )
    lines = [
        f"time to localise: first step with posterior mass >= {LOCALISED_MASS:g} within the "
        f"localisation radius (agent 0); never-localised trials censored at {steps}",
        header,
        "-" * len(header),
    ]
    for label, row in zip(labels, rows, strict=True):
        q25, q50, q75 = row.ttl_quartiles
        lines.append(
            f"{label:<{width}} {row.n_agents:>6d} {row.trials:>6d} {row.ttl_mean:>8.2f} "
            f"{q25:>6.1f} {q50:>6.1f} {q75:>6.1f} {row.never:>5d} {row.final_mass:>10.3f} "
            f"{row.plan_ms:>12.2f}"
        )
    return "\n".join(lines)
