"""The RL baselines page (``docs/results/rl.md``): the trained policies' runs (their
``config.json`` and evaluation curve ``eval.csv``) and the 20-step bench against the planners
(the store ``bench_20_steps``)."""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from infoseek.experiments.analysis import GroupSummary, summarise
from infoseek.experiments.columns import read_trials
from infoseek.experiments.pages.bench_commands import bench_commands
from infoseek.experiments.pages.markdown import code_block, display_path, page_text, table
from infoseek.experiments.pages.provenance import provenance_section, read_provenance
from infoseek.experiments.pages.report import by_group
from infoseek.experiments.policy_labels import display_name, shipped_models_dir

__all__ = ["BENCH_STORE", "rl_page"]

#: The bench store under the RL results directory.
BENCH_STORE = "bench_20_steps"
_SHIPPED = "policy:shipped/ppo_bearings_v0_4agents"

_INTRO = (
    'The PPO policy shipped as `infoseek.baselines.shipped_model("ppo_bearings_v0_4agents")` '
    "(the default shipped model is now the imitation policy of the "
    "[learned-policy page](learned.md)), files in "
    "`baselines/models/ppo_bearings_v0_4agents/` (`model.zip`, `config.json`, the training "
    "curve `eval.csv`), was trained on `bearings_v0` (4 agents, continuous turn rates, the "
    "adaptive-entropy reduction reward) on the batched vector env by `infoseek train`; the "
    "shipped model is a checkpoint of that run, chosen as the better of the checkpoints "
    "benchmarked. The other runs below are kept under `experiments/results/rl/`. Training is "
    "reproducible from the settings in each run's `config.json` (`infoseek train --help`)."
)
_TRIED = (
    "What the runs vary: more training on the batched simulator (the shipped run against the "
    "earlier fixed-grid-reward policy) and episodes as long as the evaluation (`--env-kwarg "
    "max_cycles=20`, `ppo_20_step_episodes`), both in the bench table; and, in "
    "`ppo_scaled_features_gamma0995` (not in the bench; its last evaluation is in the runs "
    "table), a discount close to 1 with scaled rather than egocentric features. With a "
    "discount close to 1 the summed entropy reduction of an episode is nearly the same for "
    "every policy that localises eventually, so the return hardly rewards localising *early*; "
    "the egocentric features (`infoseek train --features egocentric`, the default, "
    "`infoseek.baselines.features`) hand the network the estimate, team-mates and domain "
    "centre in the vehicle's own frame and the belief spread, computed from the observation. "
    "The separate effects of these two changes were not measured with full runs.\n\n"
    "`tests/test_baselines.py::test_shipped_model_beats_random_policy` checks that the shipped "
    "policy beats `RandomPolicy` on the mean final posterior mass over seeded 20-step episodes."
)


def _last_evaluation(run: Path) -> Mapping[str, str]:
    """The last row of a run's ``eval.csv``."""
    with open(run / "eval.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise ValueError(f"{run / 'eval.csv'}: no evaluation")
    return rows[-1]


def _runs_table(runs: Sequence[Path]) -> str:
    """One row per training run: its settings and its last evaluation."""
    cells = []
    for run in runs:
        config = json.loads((run / "config.json").read_text())
        last = _last_evaluation(run)
        hyper = config.get("hyperparameters", {})
        cells.append(
            [
                f"`{display_path(run)}`",
                str(config.get("algo")),
                str(config.get("features") or "scaled"),
                f"{hyper.get('gamma')}",
                str(config.get("n_envs")),
                str(config.get("env_kwargs", {}).get("max_cycles", "default")),
                f"{int(config['trained_timesteps']):,}",
                f"{float(last['wall_seconds']) / 60:.1f} min",
                f"{float(last['mean_posterior_mass']):.3f} ({last['n_episodes']} episodes)",
            ]
        )
    header = [
        "run",
        "algo",
        "features",
        "gamma",
        "envs",
        "episode steps",
        "transitions",
        "time to last evaluation",
        "last evaluation: mean posterior mass",
    ]
    return table(header, cells)


def _bench_table(rows: Mapping[tuple[str, int], GroupSummary], steps: int) -> str:
    """The planners and policies of the bench, best final mass first."""
    ordered = sorted(rows.values(), key=lambda row: -row.final_mass)
    cells = [
        [
            f"`{display_name(row.planner)}`",
            f"{row.final_mass:.3f}",
            f"{row.trials - row.never} / {row.trials}",
            f"{row.ttl_mean:.2f} ({' / '.join(f'{q:g}' for q in row.ttl_quartiles)})",
            f"{row.plan_ms:.2f} ms",
        ]
        for row in ordered
    ]
    header = [
        "policy",
        f"final posterior mass (mean of {ordered[0].trials})",
        f"localised by step {steps}",
        "time to localise mean (q25 / median / q75)",
        "decision latency per step",
    ]
    return table(header, cells)


def _goal(rows: Mapping[tuple[str, int], GroupSummary]) -> str:
    """The goal: the shipped policy matching single-node's mean final mass."""
    shipped, single = rows[_SHIPPED, 4], rows["single", 4]
    met = "met" if shipped.final_mass >= single.final_mass else "missed"
    return (
        "**The goal (the shipped policy matching `SingleNodePlanner`'s mean final posterior "
        f"mass) is {met}**: {shipped.final_mass:.3f} against {single.final_mass:.3f}; on time "
        f"to localise the shipped policy takes {shipped.ttl_mean:.2f} steps against "
        f"{single.ttl_mean:.2f}."
    )


def rl_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the RL page.

    Args:
        results: The RL results directory (the bench store :data:`BENCH_STORE` and the
            training runs' directories in it).
        page: Where the page is written.
    """
    results, page = Path(results), Path(page)
    store = results / BENCH_STORE
    provenance = read_provenance(store)
    steps = int(provenance.manifest["config"]["steps"])
    rows = by_group(summarise(read_trials(store), steps))
    runs = [shipped_models_dir() / "ppo_bearings_v0_4agents"] + sorted(
        path.parent for path in results.glob("*/config.json")
    )
    commands = [
        *bench_commands(store, provenance.manifest["config"], provenance.groups),
        f"infoseek claims {display_path(store)}",
        f"infoseek page rl --results {display_path(results)} --out {display_path(page)}",
    ]
    return page_text(
        [
            "# RL baselines",
            _INTRO,
            "## Training runs",
            _runs_table(runs),
            "## Against the planners",
            f"Seeded {steps}-step episodes (at the environment's full episode length every "
            "policy ends localised, so the metric no longer separates them), trial `k` of "
            "every group on the same target; time to localise censored at the episode length, "
            "latencies measured inside the trials:",
            code_block("\n".join(commands), "bash"),
            _bench_table(rows, steps),
            _goal(rows),
            _TRIED,
            provenance_section(provenance),
        ]
    )
