"""Episodes labelled by an expert planner: the data of behaviour cloning and DAgger.

One episode is run on the parallel environment (built with ``belief_in_infos=True``). At every
step the expert planner is asked what each agent should do, from that agent's own belief
(``infos[agent]["belief"]``; the planners never read the target), and every agent's
``(observation, expert action)`` pair is kept. What the vehicles then *do* is, per step and for
the whole team,

* the expert's actions with probability ``beta``,
* the learner's (the current policy, deterministic) otherwise,

the mixture of DAgger (Ross, Gordon & Bagnell, AISTATS 2011): with ``beta = 1`` the episode is
the expert's own (behaviour cloning); with ``beta < 1`` the labels cover the states the learner
itself reaches, where its mistakes take it. The mixing draws come from a generator seeded with
the episode, so a batch of episodes is reproducible.

Episodes run in worker processes (``num_cpus >= 1``, spawned, one BLAS and one torch thread
each) or in this process (``num_cpus = 0``); the result is the same either way.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.registry import INFORMATION_PLANNERS, PLANNER_CLASSES

__all__ = [
    "EXPERTS",
    "LabelledBatch",
    "RolloutTask",
    "build_expert",
    "rollout_pool",
    "run_rollouts",
]

#: Expert name -> planner class name in :mod:`infoseek.planners`: the information planners.
EXPERTS: dict[str, str] = {name: PLANNER_CLASSES[name] for name in INFORMATION_PLANNERS}


def build_expert(name: str, env: Any, seed: int) -> Any:
    """The planner ``name`` (:data:`EXPERTS`) for ``env``, seeded with ``seed``.

    Raises:
        ValueError: Unknown name, or a planner that cannot serve ``env`` (its message).
    """
    import infoseek.planners as planners

    if name not in EXPERTS:
        raise ValueError(f"expert must be one of {sorted(EXPERTS)}, got {name!r}")
    return getattr(planners, EXPERTS[name]).from_env(env, seed=seed)


@dataclass(frozen=True)
class RolloutTask:
    """Episodes one worker runs.

    Attributes:
        env_id: Registered environment id.
        env_kwargs: Environment keywords (``belief_in_infos`` is added).
        expert: Expert name (:data:`EXPERTS`).
        model_path: The learner's ``model.zip`` (``None``: the expert drives, ``beta`` ignored).
        beta: Probability that the expert's actions are executed at a step.
        seeds: One environment seed per episode.
        steps: Steps per episode (at most the environment's ``max_cycles``).
    """

    env_id: str
    env_kwargs: Mapping[str, Any]
    expert: str
    model_path: str | None
    beta: float
    seeds: tuple[int, ...]
    steps: int


@dataclass(frozen=True)
class LabelledBatch:
    """Expert-labelled agent states.

    Attributes:
        observations: ``(n, obs_dim)`` float32 observations.
        actions: ``(n, action_dim)`` float32 expert actions for them.
        expert_seconds: Wall time spent in the expert's ``act`` calls.
        learner_steps: Steps whose executed actions were the learner's.
        steps: Steps run.
        episode_masses: Mean posterior mass over the agents at the end of each episode.
    """

    observations: NDArray[np.float32]
    actions: NDArray[np.float32]
    expert_seconds: float = 0.0
    learner_steps: int = 0
    steps: int = 0
    episode_masses: tuple[float, ...] = field(default=())

    @staticmethod
    def concatenate(batches: Sequence[LabelledBatch]) -> LabelledBatch:
        """One batch holding every row of ``batches`` (in order)."""
        return LabelledBatch(
            observations=np.concatenate([b.observations for b in batches]),
            actions=np.concatenate([b.actions for b in batches]),
            expert_seconds=sum(b.expert_seconds for b in batches),
            learner_steps=sum(b.learner_steps for b in batches),
            steps=sum(b.steps for b in batches),
            episode_masses=tuple(m for b in batches for m in b.episode_masses),
        )


def _limit_threads() -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import threadpoolctl
    import torch

    torch.set_num_threads(1)
    threadpoolctl.threadpool_limits(1)


def _run_task(task: RolloutTask) -> LabelledBatch:
    """Run the episodes of ``task`` (module docstring)."""
    import time

    from infoseek.baselines.policy import load_policy
    from infoseek.envs import make

    env = make(task.env_id, **{**task.env_kwargs, "belief_in_infos": True})
    learner = None if task.model_path is None else load_policy(task.model_path, env)
    observations_out: list[NDArray[np.float32]] = []
    actions_out: list[NDArray[np.float32]] = []
    expert_seconds, learner_steps, steps, masses = 0.0, 0, 0, []
    for seed in task.seeds:
        expert = build_expert(task.expert, env, seed)
        mixing = np.random.default_rng([seed, 7919])
        observations, infos = env.reset(seed=seed)
        for _ in range(task.steps):
            if not env.agents:
                break
            start = time.perf_counter()
            labels = expert.act(observations, infos)
            expert_seconds += time.perf_counter() - start
            for agent in observations:
                observations_out.append(np.asarray(observations[agent], dtype=np.float32))
                actions_out.append(np.asarray(labels[agent], dtype=np.float32).reshape(-1))
            actions = labels
            if learner is not None and mixing.random() >= task.beta:
                actions = learner.act(observations, infos)
                learner_steps += 1
            observations, _, _, _, infos = env.step(actions)
            steps += 1
        masses.append(float(np.mean([infos[a]["posterior_mass"] for a in env.possible_agents])))
    env.close()
    return LabelledBatch(
        observations=np.stack(observations_out),
        actions=np.stack(actions_out),
        expert_seconds=expert_seconds,
        learner_steps=learner_steps,
        steps=steps,
        episode_masses=tuple(masses),
    )


def run_rollouts(
    template: RolloutTask, num_cpus: int, pool: ProcessPoolExecutor | None = None
) -> LabelledBatch:
    """Run ``template``'s episodes, split over ``num_cpus`` workers of ``pool`` (or in this
    process when ``num_cpus == 0`` or ``pool is None``), rows in seed order."""
    if num_cpus <= 0 or pool is None or len(template.seeds) < 2:
        return _run_task(template)
    chunks = [c for c in np.array_split(np.asarray(template.seeds), num_cpus) if c.size]
    tasks = [
        RolloutTask(**{**template.__dict__, "seeds": tuple(int(s) for s in chunk)})
        for chunk in chunks
    ]
    return LabelledBatch.concatenate(list(pool.map(_run_task, tasks)))


def rollout_pool(num_cpus: int) -> ProcessPoolExecutor | None:
    """A spawned pool of ``num_cpus`` single-threaded workers (``None`` for 0)."""
    if num_cpus <= 0:
        return None
    return ProcessPoolExecutor(
        max_workers=num_cpus, mp_context=get_context("spawn"), initializer=_limit_threads
    )
