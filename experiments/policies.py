"""Scripted policies by name, for the command line and the benchmark harness."""

from __future__ import annotations

from typing import Any

import infoseek.planners as planners

#: Command-line name -> class name in :mod:`infoseek.planners`.
PLANNER_CLASSES: dict[str, str] = {
    "pairwise": "PairwiseNodePlanner",
    "single": "SingleNodePlanner",
    "joint": "JointPlanner",
    "horizon": "RecedingHorizonPlanner",
    "random": "RandomPolicy",
    "lawnmower": "LawnmowerPolicy",
}
PLANNER_NAMES: list[str] = list(PLANNER_CLASSES)


def make_policy(name: str, env: Any, seed: int | None = None, **options: Any) -> Any:
    """Build the scripted policy called ``name`` for ``env``.

    Args:
        name: One of :data:`PLANNER_NAMES`.
        env: The environment the policy will act in (parallel API).
        seed: Seed of the policy's own random stream (planning-particle subsampling, random
            actions).
        **options: Planner options, passed to ``from_env``.

    Returns:
        An object with ``act(observations, infos) -> actions``.
    """
    if name not in PLANNER_CLASSES:
        raise ValueError(f"unknown planner {name!r}; expected one of {PLANNER_NAMES}")
    cls = getattr(planners, PLANNER_CLASSES[name])
    return cls.from_env(env, seed=seed, **options)
