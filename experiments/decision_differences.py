r"""Pairwise-node's decisions against single-node's in the same states: the engine of the decisions
studies (:mod:`infoseek.experiments.studies.decisions` on ``bearings_v0``,
:mod:`infoseek.experiments.studies.beacon_mechanism` on the beacon).

Pairwise-node (eq. 22) adds to each vehicle's single-node utility (eq. 20) the pairwise terms
with the others' planned observations; its gain over single-node (Claim A) can only come from
the steps at which that changes the chosen control. Episodes are driven by the pairwise-node
planner, and at every step a single-node planner (its own seed, its own plan history) is asked
for its actions in the same state, on the same beliefs; single-node's choice is not executed, so
the states are pairwise-node's. Trial ``k`` of fleet size ``n`` uses the seeds of trial ``k`` of
the groups ``pairwise/n`` and ``single/n`` of a bench run on the setting's environment id with
the same root seed (:func:`~infoseek.experiments.seeds.trial_seeds`): the episode is the stored
pairwise-node trial ``k`` of such a run, and its target that of every group's trial ``k``.

The difference of two actions of one vehicle is their largest per-component absolute
difference, :math:`d = \max_i |u^{\mathrm{single}}_i - u^{\mathrm{pairwise}}_i|` (the
absolute difference of the airplanes' one turn rate); an agent-step *differs* when :math:`d`
exceeds the setting's threshold, 10 % of the control range in both settings of the studies:
0.1 rad/s of the airplanes' turn-rate range [-0.5, 0.5] rad/s, 0.2 units/s^2 of the
quadrotors' per-axis acceleration range [-1, 1] units/s^2.

Reported per fleet size and phase of the search (the setting's step ranges): the fraction of
agent-steps that differ, with its standard error over trials, and the mean difference ``d``.

The rows are kept in ``OUT/decisions.json`` (:func:`write_decisions`): the environment id, its
keyword arguments (only when there are any), the threshold under the key
``different_<quantity>`` (``different_turn_rate``, ``different_acceleration``) and the rows;
``OUT/decisions.md`` is their table (:func:`format_decisions`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from threadpoolctl import threadpool_limits

from infoseek.experiments.environments import default_steps, make_env
from infoseek.experiments.policies import make_policy
from infoseek.experiments.seeds import trial_seeds

__all__ = [
    "BEARINGS_DECISIONS",
    "DecisionRow",
    "DecisionSetting",
    "decision_rows",
    "format_decisions",
    "largest_component_difference",
    "read_decisions",
    "summarise_differences",
    "trial_differences",
    "write_decisions",
]


def largest_component_difference(shadow: ArrayLike, action: ArrayLike) -> float:
    """``max_i |shadow_i - action_i|`` of two actions of one vehicle."""
    delta = np.asarray(shadow, float) - np.asarray(action, float)
    return float(np.max(np.abs(delta)))


@dataclass(frozen=True)
class DecisionSetting:
    """Where the decisions are compared and how.

    Attributes:
        env: Environment id (it enters the trial seeds: module docstring).
        env_kwargs: Its keyword arguments.
        threshold: An agent-step differs when the difference exceeds this (action units).
        quantity: What an action is, as named in the table and the JSON key
            (``"turn-rate"``, ``"acceleration"``).
        unit: The actions' unit (``"rad/s"``, ``"units/s^2"``).
        difference: The column title's name of the difference.
        phases: Step ranges ``[start, stop)`` reported.
        distance: The difference of two actions, ``distance(single's, pairwise's)``.
    """

    env: str
    env_kwargs: Mapping[str, Any]
    threshold: float
    quantity: str
    unit: str
    difference: str
    phases: tuple[tuple[int, int], ...]
    distance: Callable[[ArrayLike, ArrayLike], float] = field(
        default_factory=lambda: largest_component_difference, compare=False
    )

    @property
    def threshold_key(self) -> str:
        """The threshold's key in ``decisions.json``."""
        return "different_" + self.quantity.replace("-", "_").replace(" ", "_")


#: The ablation's setting: ``bearings_v0``, turn rates 0.1 rad/s apart differ.
BEARINGS_DECISIONS = DecisionSetting(
    env="bearings_v0",
    env_kwargs={},
    threshold=0.1,
    quantity="turn-rate",
    unit="rad/s",
    difference="abs. turn-rate difference",
    phases=((0, 1), (1, 5), (5, 10), (10, 20), (20, 60)),
)


@dataclass(frozen=True)
class DecisionRow:
    """One fleet size and phase.

    Attributes:
        n_agents: Fleet size.
        start: First step of the phase.
        stop: One past its last step.
        trials: Trials with at least one step in the phase.
        differ: Mean over trials of the fraction of agent-steps whose actions differ.
        differ_se: Its standard error over trials.
        mean_abs_difference: Mean difference of the actions (the setting's distance, in its
            unit) over all agent-steps.
    """

    n_agents: int
    start: int
    stop: int
    trials: int
    differ: float
    differ_se: float
    mean_abs_difference: float


def trial_differences(
    n_agents: int, trial: int, seed: int = 0, setting: DecisionSetting = BEARINGS_DECISIONS
) -> np.ndarray:
    """``(steps, n_agents)`` differences ``distance(single, pairwise)`` along one pairwise
    episode (one BLAS thread, as a stored trial).

    The episode runs the environment's full length, ``max_cycles`` (the setting's keyword
    arguments may set it; ``NaN`` rows after the episode ends early).
    """
    steps = default_steps(setting.env, setting.env_kwargs)
    env_seed, policy_seed = trial_seeds(seed, setting.env, "pairwise", n_agents, trial)
    _, shadow_seed = trial_seeds(seed, setting.env, "single", n_agents, trial)
    env = make_env(setting.env, n_agents=n_agents, **{"max_cycles": steps, **setting.env_kwargs})
    differences = np.full((steps, n_agents), np.nan)
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            observations, infos = env.reset(seed=env_seed)
            pairwise = make_policy("pairwise", env, seed=policy_seed)
            single = make_policy("single", env, seed=shadow_seed)
            for step in range(steps):
                if not env.agents:
                    break
                actions = pairwise.act(observations, infos)
                shadow = single.act(observations, infos)
                for agent, action in actions.items():
                    index = env.possible_agents.index(agent)
                    differences[step, index] = setting.distance(shadow[agent], action)
                observations, _, _, _, infos = env.step(actions)
    finally:
        env.close()
    return differences


def summarise_differences(
    n_agents: int, per_trial: Sequence[np.ndarray], setting: DecisionSetting = BEARINGS_DECISIONS
) -> list[DecisionRow]:
    """The rows of one fleet size from its trials' :func:`trial_differences` (a phase without
    a finite step in any trial is left out)."""
    rows = []
    for start, stop in setting.phases:
        fractions, magnitudes = [], []
        for differences in per_trial:
            phase = differences[start:stop]
            phase = phase[np.isfinite(phase)]
            if phase.size:
                fractions.append(float(np.mean(phase > setting.threshold)))
                magnitudes.append(phase)
        if not fractions:
            continue
        values = np.asarray(fractions)
        se = float(values.std(ddof=1) / np.sqrt(values.size)) if values.size > 1 else float("nan")
        rows.append(
            DecisionRow(
                n_agents=n_agents,
                start=start,
                stop=stop,
                trials=int(values.size),
                differ=float(values.mean()),
                differ_se=se,
                mean_abs_difference=float(np.mean(np.concatenate(magnitudes))),
            )
        )
    return rows


def decision_rows(
    trials: int,
    fleets: Sequence[int],
    seed: int = 0,
    setting: DecisionSetting = BEARINGS_DECISIONS,
) -> list[DecisionRow]:
    """Every fleet size's rows (runs ``trials`` pairwise episodes per fleet size)."""
    rows: list[DecisionRow] = []
    for n_agents in fleets:
        per_trial = [trial_differences(n_agents, k, seed, setting) for k in range(trials)]
        rows.extend(summarise_differences(n_agents, per_trial, setting))
    return rows


def format_decisions(
    rows: Sequence[DecisionRow], setting: DecisionSetting = BEARINGS_DECISIONS
) -> str:
    """A Markdown table of the rows."""
    lines = [
        f"| n_v | steps | trials | agent-steps that differ | mean {setting.difference} |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| {row.n_agents} | {row.start}-{row.stop - 1} | {row.trials} "
            f"| {100 * row.differ:.1f} +- {100 * row.differ_se:.1f} % "
            f"| {row.mean_abs_difference:.3f} {setting.unit} |"
        )
    return "\n".join(lines)


def write_decisions(
    out: Path, rows: Sequence[DecisionRow], setting: DecisionSetting = BEARINGS_DECISIONS
) -> list[Path]:
    """Write ``OUT/decisions.md`` and ``OUT/decisions.json`` (module docstring); returns the
    paths."""
    out.mkdir(parents=True, exist_ok=True)
    table = out / "decisions.md"
    table.write_text(format_decisions(rows, setting) + "\n")
    data = out / "decisions.json"
    payload: dict[str, Any] = {"env": setting.env}
    if setting.env_kwargs:
        payload["env_kwargs"] = dict(setting.env_kwargs)
    payload[setting.threshold_key] = setting.threshold
    payload["rows"] = [asdict(row) for row in rows]
    data.write_text(json.dumps(payload, indent=2) + "\n")
    return [table, data]


def read_decisions(out: Path, setting: DecisionSetting | None = None) -> list[DecisionRow] | None:
    """The rows stored by :func:`write_decisions` in ``out`` (``None`` when there are none).

    Args:
        out: The directory of ``decisions.json``.
        setting: If given, the stored environment, keyword arguments and threshold must be
            its own.

    Raises:
        ValueError: The file was written for another setting than ``setting``.
    """
    path = out / "decisions.json"
    if not path.exists():
        return None
    payload = json.loads(path.read_text())
    if setting is not None:
        stored = (payload["env"], payload.get("env_kwargs", {}), payload.get(setting.threshold_key))
        wanted = (setting.env, json.loads(json.dumps(dict(setting.env_kwargs))), setting.threshold)
        if stored != wanted:
            raise ValueError(
                f"{path} holds the decisions of env {stored[0]!r} with {stored[1]!r} and "
                f"{setting.threshold_key} {stored[2]!r}, not of {setting.env!r} with "
                f"{wanted[1]!r} and {setting.threshold!r}"
            )
    return [DecisionRow(**row) for row in payload["rows"]]
