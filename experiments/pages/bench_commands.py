"""The ``infoseek`` command lines that reproduce a store's groups, as a page prints them.

A group of ``k`` trials stored from trial 0 is rerun (or resumed) by ``infoseek bench`` with the
store's environment, keywords, seed and episode length and ``--trials k``; groups with the same
fleet size and trial count share one command. Trained policies are named by their model file
(:func:`~infoseek.experiments.policy_labels.policy_file`), relative to the working directory.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from typing import Any

from infoseek.experiments.environments import default_steps
from infoseek.experiments.pages.markdown import display_path
from infoseek.experiments.pages.provenance import GroupTime
from infoseek.experiments.policy_labels import is_policy, policy_file

__all__ = ["bench_commands"]


def _planner_option(label: str, store: str | os.PathLike[str]) -> str:
    """``--planner LABEL``, or ``--policy FILE`` for a trained policy."""
    if is_policy(label):
        return f"--policy {display_path(policy_file(label, store))}"
    return f"--planner {label}"


def _config_options(config: Mapping[str, Any]) -> str:
    """``--env ENV`` with one ``--env-kwarg`` per keyword and ``--steps`` where the episode is
    not the env's own."""
    env, kwargs = config["env"], dict(config.get("env_kwargs") or {})
    options = [f"--env {env}"]
    options.extend(
        f"--env-kwarg {key}={json.dumps(value, separators=(',', ':'))}"
        for key, value in sorted(kwargs.items())
    )
    if int(config["steps"]) != default_steps(env, kwargs):
        options.append(f"--steps {config['steps']}")
    return " ".join(options)


def bench_commands(
    store: str | os.PathLike[str],
    config: Mapping[str, Any],
    groups: Iterable[GroupTime],
) -> list[str]:
    """One ``infoseek bench`` command per (fleet size, trial count) of ``groups``, in the
    groups' order of first appearance.

    Args:
        store: The store directory (``--out``).
        config: Its manifest's ``config``.
        groups: The groups to reproduce.
    """
    shared: dict[tuple[int, int], list[str]] = {}
    for group in groups:
        shared.setdefault((group.n_agents, group.trials), []).append(group.planner)
    options = _config_options(config)
    return [
        "infoseek bench "
        + options
        + " "
        + " ".join(_planner_option(label, store) for label in planners)
        + f" --agents {n_agents} --trials {trials} --seed {config['seed']}"
        + f" --out {display_path(store)}"
        for (n_agents, trials), planners in shared.items()
    ]
