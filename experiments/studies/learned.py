"""The learned-policy study (``infoseek reproduce learned``): policies trained to act as the MI
planners do, against those planners, reported over training seeds.

**Settings** (:data:`SETTINGS`): each names an environment, the planner imitated and the
observation; it is trained once per seed (:data:`TRAINING_SEEDS`) by ``infoseek train --algo
dagger`` (:mod:`infoseek.baselines.imitation`) into ``OUT/<setting>/seed_<k>/``:

* ``bearings_pairwise``: ``bearings_v0``, 4 airplanes, imitating ``PairwiseNodePlanner``, with
  the belief-moment observation block (``belief_moments=True``);
* ``bearings_pairwise_grid_only``: the same without that block (the 8 x 8 grid and the MMSE
  estimate only, the observation every earlier policy had): the feature ablation;
* ``beacon_single``: ``beacon_v0``, 4 quadrotors, imitating ``SingleNodePlanner``.

**RL fine-tuning** (:data:`FINE_TUNED`, one run): PPO on the environment's entropy-reduction
reward from the weights of ``bearings_pairwise``'s shipped seed (:func:`fine_tune_command`).

**Benchmarks** (:data:`BENCHES`): one store each, written by ``infoseek bench`` with root seed 0,
so trial ``k`` faces the same target in every store and group (paired, also across stores):

* ``bench_bearings``: 40-step episodes, the pairwise-node and single-node planners, every
  ``bearings_pairwise`` policy and the fine-tuned one, 500 trials;
* ``bench_bearings_grid_only``: the ``bearings_pairwise_grid_only`` policies (their observation
  lacks the block, so they need a store of their own), 500 trials;
* ``bench_bearings_random_walk``: a moving target (``target_motion="random_walk"``), pairwise
  planner and the ``bearings_pairwise`` policies, 200 trials (generalisation, no target);
* ``bench_beacon``: ``beacon_v0``'s 40-step episodes, single-node and the ``beacon_single``
  policies, 300 trials.

**Metrics** per group: mean time to localise (agent 0's posterior mass within the localisation
radius reaches 0.9, censored at 40) and mean posterior mass at step 20, over the trials. Across
the training seeds of a setting: the interquartile mean (``scipy.stats.trim_mean(x, 0.25)``) of
the per-seed means with a 95 % percentile bootstrap interval over seeds
(``scipy.stats.bootstrap``), as rliable / marl-eval report. Against a planner, per seed: the
paired difference over trials, its standard error and a one-sided Wilcoxon signed-rank p.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from infoseek.experiments.analysis import (
    Trial,
    masses_by_trial,
    paired_matrix,
    times_to_localise,
    wilcoxon_faster,
)
from infoseek.experiments.bench import BenchPlan, plan_bench

__all__ = [
    "BENCHES",
    "FINE_TUNED",
    "MASS_STEP",
    "SETTINGS",
    "TRAINING_SEEDS",
    "BenchSpec",
    "Interval",
    "PairedResult",
    "Setting",
    "fine_tune_command",
    "TrainingRun",
    "interquartile_mean",
    "paired_result",
    "plot_learning_curves",
    "read_run",
    "run_directories",
    "selected_run",
]

#: Training seeds of every setting.
TRAINING_SEEDS: tuple[int, ...] = (0, 1, 2, 3, 4)
#: The step whose posterior mass is compared.
MASS_STEP = 20


@dataclass(frozen=True)
class Setting:
    """One trained configuration (module docstring).

    Attributes:
        name: Its folder under the study's directory.
        env: Environment id.
        expert: The planner imitated.
        belief_moments: Whether the observation has the belief-moment block.
        options: Further ``infoseek train`` options (``--iterations``, ``--episodes``).
    """

    name: str
    env: str
    expert: str
    belief_moments: bool
    options: tuple[str, ...] = ()

    def train_command(self, seed: int, out: Path | str) -> list[str]:
        """The ``infoseek train`` arguments of seed ``seed`` into ``out``."""
        return [
            "train", "--algo", "dagger", "--env", self.env, "--agents", "4",
            "--expert", self.expert, "--seed", str(seed),
            "--env-kwarg", f"belief_moments={str(self.belief_moments).lower()}",
            *self.options, "--out", str(out),
        ]  # fmt: skip


SETTINGS: tuple[Setting, ...] = (
    Setting("bearings_pairwise", "bearings_v0", "pairwise", True),
    Setting("bearings_pairwise_grid_only", "bearings_v0", "pairwise", False),
    Setting(
        "beacon_single",
        "beacon_v0",
        "single",
        True,
        ("--iterations", "7", "--episodes", "40", "--eval-episodes", "20"),
    ),
)


#: The run directory of the PPO fine-tuning of ``bearings_pairwise``'s shipped seed.
FINE_TUNED = "bearings_pairwise_ppo"


def fine_tune_command(results: Path | str) -> list[str]:
    """``infoseek train`` arguments of the RL fine-tuning: PPO on the entropy-reduction reward
    from the weights of ``bearings_pairwise``'s shipped seed (:func:`selected_run`), 500k
    transitions, a small step size so the first updates do not undo the imitation."""
    results = Path(results)
    start = selected_run([read_run(path) for path in run_directories(results, "bearings_pairwise")])
    return [
        "train", "--algo", "ppo", "--env", "bearings_v0", "--agents", "4",
        "--init", str(start.path / "model.zip"), "--env-kwarg", "belief_moments=true",
        "--timesteps", "500000", "--n-envs", "16", "--hyper", "n_steps=60",
        "--hyper", "batch_size=480", "--hyper", "learning_rate=0.0001",
        "--eval-freq", "100000", "--eval-episodes", "20", "--checkpoint-freq", "0",
        "--out", str(results / FINE_TUNED),
    ]  # fmt: skip


@dataclass(frozen=True)
class BenchSpec:
    """One benchmark store of the study (module docstring).

    Attributes:
        name: The store's folder under the study's directory.
        env: Environment id.
        env_kwargs: Environment keywords.
        planners: Scripted planners benchmarked.
        setting: The setting whose policies are benchmarked.
        trials: Trials per group.
        steps: Steps per trial.
        runs: Further run directories (under the study's) whose models are benchmarked.
    """

    name: str
    env: str
    env_kwargs: Mapping[str, Any]
    planners: tuple[str, ...]
    setting: str
    trials: int
    steps: int = 40
    runs: tuple[str, ...] = ()

    def plan(self, results: Path) -> BenchPlan:
        """The bench plan into ``results / name``; the models must exist."""
        directories = [*run_directories(results, self.setting), *(results / r for r in self.runs)]
        policies = [str(path / "model.zip") for path in directories]
        return plan_bench(
            self.env,
            dict(self.env_kwargs),
            planners=self.planners,
            policies=policies,
            agents=[4],
            trials=self.trials,
            steps=self.steps,
            seed=0,
            out=results / self.name,
        )


BENCHES: tuple[BenchSpec, ...] = (
    BenchSpec(
        "bench_bearings",
        "bearings_v0",
        {"belief_moments": True},
        ("pairwise", "single"),
        "bearings_pairwise",
        500,
        runs=(FINE_TUNED,),
    ),
    BenchSpec(
        "bench_bearings_grid_only", "bearings_v0", {}, (), "bearings_pairwise_grid_only", 500
    ),
    BenchSpec(
        "bench_bearings_random_walk",
        "bearings_v0",
        {"belief_moments": True, "target_motion": "random_walk"},
        ("pairwise",),
        "bearings_pairwise",
        200,
    ),
    BenchSpec(
        "bench_beacon", "beacon_v0", {"belief_moments": True}, ("single",), "beacon_single", 300
    ),
)


def run_directories(results: Path, setting: str) -> list[Path]:
    """The run directory of every training seed of ``setting`` (in seed order)."""
    return [results / setting / f"seed_{seed}" for seed in TRAINING_SEEDS]


@dataclass(frozen=True)
class Interval:
    """An estimate with its 95 % interval."""

    value: float
    low: float
    high: float


def interquartile_mean(values: Sequence[float], seed: int = 0) -> Interval:
    """IQM of ``values`` with a 95 % percentile bootstrap interval (module docstring)."""
    data = np.asarray(values, dtype=np.float64)
    if data.size < 2:
        raise ValueError(f"an interquartile mean over seeds needs >= 2 values, got {data.size}")

    from scipy import stats  # imported here: slow to import (infoseek.experiments.analysis)

    def iqm(sample: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.asarray(stats.trim_mean(sample, 0.25, axis=axis))

    result = stats.bootstrap(
        (data,),
        iqm,
        n_resamples=10_000,
        confidence_level=0.95,
        method="percentile",
        random_state=np.random.default_rng(seed),
    )
    interval = result.confidence_interval
    return Interval(float(iqm(data)), float(interval.low), float(interval.high))


@dataclass(frozen=True)
class PairedResult:
    """One policy against one planner over the trials both hold.

    Attributes:
        trials: Paired trials.
        policy_ttl: The policy's mean time to localise.
        planner_ttl: The planner's mean time to localise.
        ttl_gain: Mean of planner minus policy time (> 0: the policy is faster), its standard
            error and the one-sided Wilcoxon p that the policy is faster.
        policy_mass: The policy's mean posterior mass at :data:`MASS_STEP`.
        planner_mass: The planner's.
        mass_gain: Mean of policy minus planner mass, its standard error and the one-sided
            Wilcoxon p that the policy's is higher.
        policy_ms: The policy's mean decision time per step (ms).
        planner_ms: The planner's.
    """

    trials: int
    policy_ttl: float
    planner_ttl: float
    ttl_gain: tuple[float, float, float]
    policy_mass: float
    planner_mass: float
    mass_gain: tuple[float, float, float]
    policy_ms: float
    planner_ms: float


def _mass_at(trials: Sequence[Trial], label: str, steps: int) -> dict[int, float]:
    series = masses_by_trial(trials, label, 4, steps + 1)
    return {k: float(v[MASS_STEP]) for k, v in series.items()}


def _plan_ms(trials: Sequence[Trial], label: str) -> float:
    times = [
        float(t)
        for record in trials
        if record.planner == label
        for t in record.plan_time
        if t is not None
    ]
    return 1000.0 * float(np.mean(times)) if times else float("nan")


def paired_result(
    policy_trials: Sequence[Trial],
    policy: str,
    planner_trials: Sequence[Trial],
    planner: str,
    steps: int,
) -> PairedResult:
    """``policy`` (a group of ``policy_trials``) against ``planner`` (of ``planner_trials``;
    the same store or another with the same seed), paired by trial."""
    ttl = paired_matrix(
        [
            times_to_localise(planner_trials, planner, 4, steps),
            times_to_localise(policy_trials, policy, 4, steps),
        ]
    )
    mass = paired_matrix(
        [_mass_at(policy_trials, policy, steps), _mass_at(planner_trials, planner, steps)]
    )
    if ttl.shape[0] < 2:
        raise ValueError(f"{policy} against {planner}: fewer than 2 paired trials")
    return PairedResult(
        trials=int(ttl.shape[0]),
        policy_ttl=float(ttl[:, 1].mean()),
        planner_ttl=float(ttl[:, 0].mean()),
        ttl_gain=wilcoxon_faster(ttl[:, 0], ttl[:, 1]),
        policy_mass=float(mass[:, 0].mean()),
        planner_mass=float(mass[:, 1].mean()),
        mass_gain=wilcoxon_faster(mass[:, 0], mass[:, 1]),
        policy_ms=_plan_ms(policy_trials, policy),
        planner_ms=_plan_ms(planner_trials, planner),
    )


@dataclass(frozen=True)
class TrainingRun:
    """One seed's imitation run, as its run directory holds it.

    Attributes:
        path: The run directory.
        seed: Training seed.
        curve: ``eval.csv`` columns (iteration, labelled_states, mean_posterior_mass, ...).
        expert_mean_mass: The expert's mean posterior mass on the same evaluation episodes.
        wall_seconds: Wall time of the run.
        labelled_states: Agent states labelled by the expert.
    """

    path: Path
    seed: int
    curve: dict[str, np.ndarray]
    expert_mean_mass: float
    wall_seconds: float
    labelled_states: int


def read_run(path: Path) -> TrainingRun:
    """The :class:`TrainingRun` in ``path`` (``config.json`` and ``eval.csv``)."""
    config = json.loads((path / "config.json").read_text())
    with open(path / "eval.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise ValueError(f"{path / 'eval.csv'}: no evaluation")
    curve = {key: np.array([float(row[key]) for row in rows]) for key in rows[0]}
    return TrainingRun(
        path=path,
        seed=int(config["seed"]),
        curve=curve,
        expert_mean_mass=float(config["expert_evaluation"]["mean_posterior_mass"]),
        wall_seconds=float(config["wall_seconds"]),
        labelled_states=int(config["labelled_states"]),
    )


def selected_run(runs: Sequence[TrainingRun]) -> TrainingRun:
    """The run shipped: the highest mean posterior mass at its last training evaluation (the
    first such seed on a tie), chosen without the benchmark's trials."""
    return max(runs, key=lambda run: (run.curve["mean_posterior_mass"][-1], -run.seed))


def plot_learning_curves(results: Path, out: Path) -> list[Path]:
    """``out.png`` / ``out.svg``: per setting, the learner's mean posterior mass on the
    evaluation episodes after each iteration, median and interquartile range over the training
    seeds, with the expert's median on the same episodes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from infoseek.experiments.plot import save_figure

    figure, axes = plt.subplots(1, len(SETTINGS), figsize=(4.2 * len(SETTINGS), 3.4))
    for axis, setting in zip(np.atleast_1d(axes), SETTINGS, strict=True):
        runs = [read_run(path) for path in run_directories(results, setting.name)]
        masses = np.array([run.curve["mean_posterior_mass"] for run in runs])
        iterations = runs[0].curve["iteration"]
        low, median, high = np.percentile(masses, [25, 50, 75], axis=0)
        axis.fill_between(iterations, low, high, alpha=0.3, label="learner IQR over seeds")
        axis.plot(iterations, median, marker="o", label="learner median")
        expert = float(np.median([run.expert_mean_mass for run in runs]))
        axis.axhline(expert, color="k", linestyle="--", label=f"expert ({setting.expert})")
        axis.set_title(setting.name, fontsize=10)
        axis.set_xlabel("iteration (0: behaviour cloning)")
        axis.set_ylabel("mean posterior mass, evaluation episodes")
        axis.legend(fontsize=7)
    figure.tight_layout()
    paths = [out.with_suffix(".png"), out.with_suffix(".svg")]
    for path in paths:
        save_figure(figure, path, dpi=120)
    plt.close(figure)
    return paths
