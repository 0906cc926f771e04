"""The decisions study (part of ``infoseek reproduce ablation``): how often the pairwise-node
planner changes the decision the single-node planner would make in the same state.

Pairwise-node (eq. 22) adds to each vehicle's single-node utility (eq. 20) the pairwise terms
with the others' planned observations. Its gain over single-node (Claim A) can only come from
the steps at which that changes the chosen control. This study measures it directly: episodes
of ``bearings_v0`` are driven by the pairwise-node planner (the same seeds as Fig. 1: trial
``k`` uses the environment seed of Fig. 1's trial ``k``), and at every step a single-node
planner (its own seed, its own plan history) is asked for its actions in the same state, on
the same beliefs. An agent-step *differs* when the two turn rates are more than
:data:`DIFFERENT_TURN_RATE` apart.

Reported per fleet size and phase of the search (step ranges :data:`PHASES`): the fraction of
agent-steps that differ, with its standard error over trials, and the mean absolute
turn-rate difference. Single-node's choice is not executed, so the states are pairwise-node's.

The counterfactual that goes with it is the switched planner
(:class:`infoseek.experiments.decisions.PairwiseThenSingle`: pairwise-node for the first ``k``
steps, single-node after), which the Claim A ablation
(:mod:`infoseek.experiments.studies.ablation`) runs on the same targets as single-node and
pairwise-node: if it keeps pairwise-node's gain, the gain is made by those first decisions.

The rows are kept in ``OUT/decisions.json`` (:func:`write_decisions`): the study runs its
episodes only when that file is missing.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from infoseek.experiments.environments import default_steps, make_env
from infoseek.experiments.policies import make_policy
from infoseek.experiments.seeds import trial_seeds

DECISIONS_ENV = "bearings_v0"
DEFAULT_TRIALS = 20
FLEETS = (2, 4, 10)
PHASES = ((0, 1), (1, 5), (5, 10), (10, 20), (20, 60))
"""Step ranges ``[start, stop)`` of the phases reported."""
DIFFERENT_TURN_RATE = 0.1
"""rad/s; 10 % of the airplanes' turn-rate range [-0.5, 0.5]."""


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
        mean_abs_difference: Mean absolute turn-rate difference (rad/s) over all agent-steps.
    """

    n_agents: int
    start: int
    stop: int
    trials: int
    differ: float
    differ_se: float
    mean_abs_difference: float


def trial_differences(n_agents: int, trial: int, seed: int = 0) -> np.ndarray:
    """``(steps, n_agents)`` absolute turn-rate differences ``|single - pairwise|`` along one
    pairwise episode.

    The episode runs the environment's full length (``NaN`` rows after it ends early).
    """
    steps = default_steps(DECISIONS_ENV, {})
    env_seed, policy_seed = trial_seeds(seed, DECISIONS_ENV, "pairwise", n_agents, trial)
    _, shadow_seed = trial_seeds(seed, DECISIONS_ENV, "single", n_agents, trial)
    env = make_env(DECISIONS_ENV, n_agents=n_agents, max_cycles=steps)
    differences = np.full((steps, n_agents), np.nan)
    try:
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
                delta = np.asarray(shadow[agent], float) - np.asarray(action, float)
                differences[step, index] = float(np.max(np.abs(delta)))
            observations, _, _, _, infos = env.step(actions)
    finally:
        env.close()
    return differences


def summarise_differences(n_agents: int, per_trial: Sequence[np.ndarray]) -> list[DecisionRow]:
    """The rows of one fleet size from its trials' :func:`trial_differences`."""
    rows = []
    for start, stop in PHASES:
        fractions, magnitudes = [], []
        for differences in per_trial:
            phase = differences[start:stop]
            phase = phase[np.isfinite(phase)]
            if phase.size:
                fractions.append(float(np.mean(phase > DIFFERENT_TURN_RATE)))
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
    trials: int = DEFAULT_TRIALS, fleets: Sequence[int] = FLEETS, seed: int = 0
) -> list[DecisionRow]:
    """Every fleet size's rows (runs ``trials`` pairwise episodes per fleet size)."""
    rows: list[DecisionRow] = []
    for n_agents in fleets:
        per_trial = [trial_differences(n_agents, trial, seed) for trial in range(trials)]
        rows.extend(summarise_differences(n_agents, per_trial))
    return rows


def format_decisions(rows: Sequence[DecisionRow]) -> str:
    """A Markdown table of the rows."""
    lines = [
        "| n_v | steps | trials | agent-steps that differ | mean abs. turn-rate difference |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| {row.n_agents} | {row.start}-{row.stop - 1} | {row.trials} "
            f"| {100 * row.differ:.1f} +- {100 * row.differ_se:.1f} % "
            f"| {row.mean_abs_difference:.3f} rad/s |"
        )
    return "\n".join(lines)


def write_decisions(out: Path, rows: Sequence[DecisionRow]) -> list[Path]:
    """Write ``OUT/decisions.md`` and ``OUT/decisions.json``; returns the paths."""
    out.mkdir(parents=True, exist_ok=True)
    table = out / "decisions.md"
    table.write_text(format_decisions(rows) + "\n")
    data = out / "decisions.json"
    payload = {
        "env": DECISIONS_ENV,
        "different_turn_rate": DIFFERENT_TURN_RATE,
        "rows": [asdict(row) for row in rows],
    }
    data.write_text(json.dumps(payload, indent=2) + "\n")
    return [table, data]


def read_decisions(out: Path) -> list[DecisionRow] | None:
    """The rows stored by :func:`write_decisions` in ``out`` (``None`` when there are none)."""
    path = out / "decisions.json"
    if not path.exists():
        return None
    return [DecisionRow(**row) for row in json.loads(path.read_text())["rows"]]
