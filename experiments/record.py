"""The record of one benchmark trial: the one schema that the harness writes and the studies read.

A trial (:mod:`infoseek.experiments.trial`) is one episode of ``T`` steps (``T`` the run's
episode length, unless it ended earlier). For step ``t = 0`` (after ``reset``) through ``T``,
with agent beliefs ``b_i`` (weights ``w``, positions ``x``), MMSE position estimate
``xhat_i = sum_j w_j x_j`` (eq. 12; position coordinates are never periodic), localisation
radius ``r`` (``env.unwrapped.config.localization_radius``, 1 unit as in Fig. 1) and true
position ``x*`` (``env.unwrapped.true_target()``, used only here, never by the policy):

* ``mass_agent0[t]``: ``sum_j w_j [||x_j - xhat_0|| <= r]`` of agent 0's belief, the
  probability that the target is within ``r`` of the MMSE estimate (the metric of Fig. 1);
  ``mass_team[t]``: its mean over the agents;
* ``error_agent0[t]``: ``||xhat_0 - x*||``; ``error_team[t]``: its mean over the agents;
* ``entropy_agent0[t]``, ``entropy_team[t]``: the env's belief entropy estimate
  (``infos[agent]["entropy"]``) of agent 0 and the team mean;
* ``min_separation[t]``: the smallest distance between two vehicles (``None`` with one);
* ``plan_time[t - 1]`` for ``t >= 1``: seconds the policy spent choosing the actions that led
  to step ``t`` (one ``act`` call for the whole team), so it has ``T`` entries.

A record also has its ``key`` (``"<planner>/agents=<n>/trial=<k>"``), ``planner``,
``n_agents``, ``trial``, both seeds (:mod:`infoseek.experiments.seeds`), ``radius``,
``n_steps`` (``T``), ``truth`` (the true target state at ``T``), ``recoveries``
(belief-degeneracy recoveries summed over agents and steps) and ``wall_time``. Everything except
the timing fields :data:`TIMING_FIELDS` is a deterministic function of the run configuration and
the trial, identical on every backend.

A *row* is the record as the results store keeps it (:mod:`infoseek.experiments.store`): a JSON
object with one member per field, series as lists; non-finite numbers become ``None``
(``null``). :meth:`TrialRecord.to_row` and :meth:`TrialRecord.from_row` convert.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["SERIES_FIELDS", "TIMING_FIELDS", "Series", "TrialRecord", "trial_key"]

#: A per-step series: one value per step (``None``: undefined or not finite).
Series = tuple[float | None, ...]
#: Fields that measure time and so differ between otherwise identical runs.
TIMING_FIELDS: frozenset[str] = frozenset({"plan_time", "wall_time"})


def trial_key(planner: str, n_agents: int, trial: int) -> str:
    """The unique key of one trial in a store: ``"<planner>/agents=<n_agents>/trial=<trial>"``.

    Args:
        planner: Planner label (a scripted planner name, a ``"module:callable"`` factory or a
            trained policy's ``"policy:..."`` label).
        n_agents: Number of vehicles.
        trial: Trial index within the (planner, n_agents) group.
    """
    return f"{planner}/agents={int(n_agents)}/trial={int(trial)}"


def _series(values: Sequence[Any]) -> Series:
    return tuple(None if v is None else float(v) for v in values)


@dataclass(frozen=True)
class TrialRecord:
    """One finished trial (module docstring for every field)."""

    key: str
    planner: str
    n_agents: int
    trial: int
    env_seed: int
    policy_seed: int
    radius: float
    n_steps: int
    truth: tuple[float, ...]
    recoveries: int
    wall_time: float
    plan_time: Series
    mass_agent0: Series
    mass_team: Series
    error_agent0: Series
    error_team: Series
    entropy_agent0: Series
    entropy_team: Series
    min_separation: Series

    @property
    def group(self) -> tuple[str, int]:
        """``(planner, n_agents)``."""
        return self.planner, self.n_agents

    def to_row(self) -> dict[str, Any]:
        """The stored row: one member per field, series as lists."""
        return {
            field.name: list(value) if isinstance(value, tuple) else value
            for field in dataclasses.fields(self)
            for value in (getattr(self, field.name),)
        }

    @classmethod
    def from_row(cls, row: Mapping[str, Any]) -> TrialRecord:
        """The record of a stored row (members beyond the schema are ignored).

        Raises:
            ValueError: The row lacks a field of the schema (the message names them).
        """
        missing = [name for name in FIELD_NAMES if name not in row]
        if missing:
            raise ValueError(f"trial row {row.get('key')!r} has no field(s) {missing}")
        return cls(
            key=str(row["key"]),
            planner=str(row["planner"]),
            n_agents=int(row["n_agents"]),
            trial=int(row["trial"]),
            env_seed=int(row["env_seed"]),
            policy_seed=int(row["policy_seed"]),
            radius=float(row["radius"]),
            n_steps=int(row["n_steps"]),
            truth=tuple(float(v) for v in row["truth"]),
            recoveries=int(row["recoveries"]),
            wall_time=float(row["wall_time"]),
            **{name: _series(row[name]) for name in SERIES_FIELDS},
        )


#: Every field of the schema, in order.
FIELD_NAMES: tuple[str, ...] = tuple(field.name for field in dataclasses.fields(TrialRecord))
#: The per-step series fields.
SERIES_FIELDS: tuple[str, ...] = FIELD_NAMES[FIELD_NAMES.index("plan_time") :]
