"""The learned-policy page (``docs/results/learned.md``), from the study's directory: the
training runs of every setting and the benchmark stores
(:mod:`infoseek.experiments.studies.learned`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from infoseek.experiments.analysis import format_p_value
from infoseek.experiments.columns import read_trials
from infoseek.experiments.pages.bench_commands import bench_commands
from infoseek.experiments.pages.markdown import code_block, display_path, figure, page_text, table
from infoseek.experiments.pages.provenance import (
    StoreProvenance,
    read_provenance,
    stores_section,
)
from infoseek.experiments.policy_labels import portable_label
from infoseek.experiments.studies.learned import (
    BENCHES,
    FINE_TUNED,
    MASS_STEP,
    SETTINGS,
    PairedResult,
    TrainingRun,
    fine_tune_command,
    interquartile_mean,
    paired_result,
    read_run,
    run_directories,
    selected_run,
)

__all__ = ["learned_page"]

_INTRO = (
    "Can a policy network decide as the MI planners do, at a fraction of their decision time? "
    "Each setting below is trained by `infoseek train --algo dagger` "
    "(`infoseek.baselines.imitation`) once per training seed: behaviour cloning of the planner's "
    "decisions, then DAgger iterations in which the learner drives and the planner labels every "
    "visited state from the belief that agent holds (it never sees the target). The policies "
    "then run in seeded `infoseek bench` stores beside the planners, trial `k` of every group "
    "on the same target, so each comparison is paired. Time to localise: the first step at "
    "which agent 0's posterior mass within the localisation radius reaches 0.9 (censored at "
    f"the episode length); mass: agent 0's posterior mass at step {MASS_STEP}. Across training "
    "seeds: the interquartile mean (IQM) of the per-seed means with a 95 % percentile bootstrap "
    "interval (`scipy.stats.bootstrap`), as rliable and marl-eval report. The *shipped* seed of "
    "a setting is the one whose last training evaluation (50 seeded episodes kept apart from "
    "the bench's seeds) had the highest mean posterior mass: chosen before the bench."
)


def _commands(results: Path, page: Path, provenances: Sequence[StoreProvenance]) -> list[str]:
    """The study in one command, then step by step: training, fine-tuning, each bench store
    (``provenances`` in the order of ``BENCHES``) with its claims, and this page."""
    commands = [
        f"infoseek reproduce learned --workers 2 --out {display_path(results)} "
        f"--page {display_path(page)}",
        "# the same, step by step:",
        *_train_commands(results),
        "infoseek " + " ".join(fine_tune_command(display_path(results))),
    ]
    for provenance, bench in zip(provenances, BENCHES, strict=True):
        store = results / bench.name
        commands += bench_commands(store, provenance.manifest["config"], provenance.groups)
        commands.append(f"infoseek claims {display_path(store)}")
    commands.append(
        f"infoseek page learned --results {display_path(results)} --out {display_path(page)}"
    )
    return commands


def _train_commands(results: Path) -> list[str]:
    return [
        "infoseek " + " ".join(setting.train_command(seed, display_path(path)))
        for setting in SETTINGS
        for seed, path in enumerate(run_directories(results, setting.name))
    ]


def _runs_table(results: Path) -> str:
    rows = []
    for setting in SETTINGS:
        runs = [read_run(path) for path in run_directories(results, setting.name)]
        chosen = selected_run(runs)
        for run in runs:
            rows.append(
                [
                    f"`{setting.name}`",
                    f"{run.seed}{' (shipped)' if run is chosen else ''}",
                    f"{run.labelled_states:,}",
                    f"{run.wall_seconds / 60:.1f} min",
                    f"{run.curve['mean_posterior_mass'][-1]:.3f}",
                    f"{run.expert_mean_mass:.3f}",
                ]
            )
    header = [
        "setting",
        "seed",
        "labelled agent states",
        "wall time",
        "last evaluation: mean posterior mass",
        "expert on the same episodes",
    ]
    return table(header, rows)


def _gain(values: tuple[float, float, float], digits: int) -> str:
    mean, stderr, p = values
    return f"{mean:+.{digits}f} +- {stderr:.{digits}f} (p {format_p_value(p)})"


def _comparison_cells(result: PairedResult) -> list[str]:
    """Trials, time to localise, its paired gain, mass at step 20, its paired gain."""
    return [
        str(result.trials),
        f"{result.policy_ttl:.2f} vs {result.planner_ttl:.2f}",
        _gain(result.ttl_gain, 2),
        f"{result.policy_mass:.3f} vs {result.planner_mass:.3f}",
        _gain(result.mass_gain, 3),
    ]


def _comparisons(
    results: Path, bench: str, planner: str, setting: str, planner_bench: str | None = None
) -> list[tuple[TrainingRun, PairedResult]]:
    store = results / bench
    steps = int(read_provenance(store).manifest["config"]["steps"])
    trials = read_trials(store)
    planner_trials = trials if planner_bench is None else read_trials(results / planner_bench)
    runs = [read_run(path) for path in run_directories(results, setting)]
    return [
        (
            run,
            paired_result(
                trials,
                portable_label(run.path / "model.zip", store),
                planner_trials,
                planner,
                steps,
            ),
        )
        for run in runs
    ]


def _paired_table(pairs: Sequence[tuple[TrainingRun, PairedResult]], planner: str) -> str:
    chosen = selected_run([run for run, _ in pairs])
    rows = [
        [
            f"{run.seed}{' (shipped)' if run is chosen else ''}",
            *_comparison_cells(result),
            f"{result.policy_ms:.2f} vs {result.planner_ms:.2f} ms",
        ]
        for run, result in pairs
    ]
    ttl = interquartile_mean([result.policy_ttl for _, result in pairs])
    mass = interquartile_mean([result.policy_mass for _, result in pairs])
    first = pairs[0][1]
    rows.append(
        [
            "IQM over seeds [95 % CI]",
            str(first.trials),
            f"{ttl.value:.2f} [{ttl.low:.2f}, {ttl.high:.2f}] vs {first.planner_ttl:.2f}",
            "",
            f"{mass.value:.3f} [{mass.low:.3f}, {mass.high:.3f}] vs {first.planner_mass:.3f}",
            "",
            "",
        ]
    )
    header = [
        "training seed",
        "paired trials",
        f"time to localise: policy vs `{planner}`",
        f"`{planner}` - policy (one-sided Wilcoxon: policy faster)",
        f"mass at step {MASS_STEP}: policy vs `{planner}`",
        f"policy - `{planner}` (one-sided Wilcoxon: policy higher)",
        "decision time per step",
    ]
    return table(header, rows)


def _verdict(
    pairs: Sequence[tuple[TrainingRun, PairedResult]], planner: str, latency: int, mass: bool
) -> str:
    chosen = selected_run([run for run, _ in pairs])
    result = next(r for run, r in pairs if run is chosen)
    checks = [
        (
            "time to localise",
            result.policy_ttl <= result.planner_ttl,
            f"{result.policy_ttl:.2f} against {result.planner_ttl:.2f} steps",
        ),
        (
            f"decision time <= 1/{latency} of the planner's",
            result.policy_ms * latency <= result.planner_ms,
            f"{result.policy_ms:.2f} ms against {result.planner_ms:.2f} ms "
            f"(1/{result.planner_ms / result.policy_ms:.1f})",
        ),
    ]
    if mass:
        checks.insert(
            1,
            (
                f"mass at step {MASS_STEP}",
                result.policy_mass >= result.planner_mass,
                f"{result.policy_mass:.3f} against {result.planner_mass:.3f}",
            ),
        )
    lines = [f"* {name}: **{'met' if ok else 'missed'}**, {detail}" for name, ok, detail in checks]
    return f"The shipped seed ({chosen.seed}) against `{planner}`:\n\n" + "\n".join(lines)


def _fine_tune_section(results: Path) -> str:
    """The PPO fine-tuning against the pairwise-node planner and against its starting point."""
    store = results / "bench_bearings"
    steps = int(read_provenance(store).manifest["config"]["steps"])
    trials = read_trials(store)
    tuned = portable_label(results / FINE_TUNED / "model.zip", store)
    runs = [read_run(path) for path in run_directories(results, "bearings_pairwise")]
    start = selected_run(runs)
    rows = []
    for name, label in (
        ("`pairwise`", "pairwise"),
        (f"its start (seed {start.seed})", portable_label(start.path / "model.zip", store)),
    ):
        result = paired_result(trials, tuned, trials, label, steps)
        rows.append([name, *_comparison_cells(result)])
    header = [
        "fine-tuned policy against",
        "paired trials",
        "time to localise: fine-tuned vs other",
        "other - fine-tuned (one-sided Wilcoxon: fine-tuned faster)",
        f"mass at step {MASS_STEP}: fine-tuned vs other",
        "fine-tuned - other (one-sided Wilcoxon: fine-tuned higher)",
    ]
    command = "infoseek " + " ".join(fine_tune_command(display_path(results)))
    return "\n\n".join(
        [
            "PPO on the environment's entropy-reduction reward, starting from the shipped "
            "seed's weights (one run, the `--init` option of `infoseek train`):",
            code_block(command, "bash"),
            table(header, rows),
        ]
    )


def learned_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the learned-policy page.

    Args:
        results: The study's directory (the settings' run directories, the bench stores and
            ``learning_curves.png``).
        page: Where the page is written.
    """
    results, page = Path(results), Path(page)
    provenances = [read_provenance(results / bench.name) for bench in BENCHES]
    commands = _commands(results, page, provenances)
    bearings = _comparisons(results, "bench_bearings", "pairwise", "bearings_pairwise")
    single = _comparisons(results, "bench_bearings", "single", "bearings_pairwise")
    grid_only = _comparisons(
        results, "bench_bearings_grid_only", "pairwise", "bearings_pairwise_grid_only",
        planner_bench="bench_bearings",
    )  # fmt: skip
    walk = _comparisons(results, "bench_bearings_random_walk", "pairwise", "bearings_pairwise")
    beacon = _comparisons(results, "bench_beacon", "single", "beacon_single")
    return page_text(
        [
            "# A learned policy against the MI planners",
            _INTRO,
            "## Commands",
            code_block("\n".join(commands), "bash"),
            "## Training runs",
            _runs_table(results),
            figure("Learning curves", results / "learning_curves.png", page),
            "## `bearings_v0`, 4 airplanes: against the pairwise-node planner",
            _paired_table(bearings, "pairwise"),
            _verdict(bearings, "pairwise", latency=10, mass=True),
            "Against the single-node planner (same store):",
            _paired_table(single, "single"),
            "## Beyond imitation: RL fine-tuning",
            _fine_tune_section(results),
            "## Feature ablation: without the belief-moment block",
            "The same training with the observation every earlier policy had (the 8 x 8 belief "
            "grid and the MMSE estimate, no `belief_moments`), in a store of its own with the "
            "same seed, so its trials pair with the pairwise-node planner's above:",
            _paired_table(grid_only, "pairwise"),
            "## Generalisation",
            'A moving target (`target_motion="random_walk"`), the policies trained on a '
            "stationary one:",
            _paired_table(walk, "pairwise"),
            "Other fleet sizes: the observation holds the positions of the `n_v - 1` team-mates "
            "(`others_relative_positions`), so a policy trained with 4 airplanes cannot take the "
            "observation of 2 or 10; acting with another fleet size needs another layout "
            "(e.g. the nearest `k` team-mates), which this study does not train.",
            "## `beacon_v0`, 4 quadrotors: against the single-node planner",
            _paired_table(beacon, "single"),
            _verdict(beacon, "single", latency=20, mass=False),
            stores_section(provenances),
        ]
    )
