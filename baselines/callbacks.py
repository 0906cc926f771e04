"""Training callbacks: progress bar, evaluation curve (TensorBoard + CSV), checkpoints.

* :class:`TqdmProgressCallback` -- a ``tqdm`` bar over the run's timesteps (one timestep = one
  agent transition), starting at the resumed count.
* :class:`PeriodicEvaluationCallback` -- every ``eval_freq`` timesteps (checked between
  rollouts, i.e. after each policy update, and once at the end) runs seeded episodes on
  the real parallel environment with the current policy (deterministic actions,
  :func:`infoseek.baselines.evaluation.evaluate_policy`) and records the means under ``eval/``
  in TensorBoard and as one row of the training-curve CSV (columns :data:`CURVE_COLUMNS`).
* :class:`PruningCheckpointCallback` -- SB3's ``CheckpointCallback`` (``checkpoints/
  model_<timesteps>_steps.zip``) that also keeps only the newest replay-buffer file of off-policy
  runs (each can be hundreds of MB).
"""

from __future__ import annotations

import csv
import re
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback
from tqdm.auto import tqdm

from infoseek.baselines.evaluation import evaluate_policy
from infoseek.baselines.policy import TrainedPolicy

__all__ = [
    "CURVE_COLUMNS",
    "PeriodicEvaluationCallback",
    "PruningCheckpointCallback",
    "TqdmProgressCallback",
    "truncate_curve",
]

#: Columns of the training-curve CSV (``DIR/eval.csv``).
CURVE_COLUMNS = (
    "timesteps",
    "mean_entropy_reduction",
    "mean_final_posterior_mass",
    "mean_posterior_mass",
    "mean_return",
    "mean_episode_length",
    "n_episodes",
    "wall_seconds",
)

_REPLAY_PATTERN = re.compile(r"_replay_buffer_(\d+)_steps\.pkl$")


def truncate_curve(path: Path, max_timesteps: int) -> None:
    """Drop rows of the curve CSV at ``path`` past ``max_timesteps`` (used when resuming)."""
    if not path.is_file():
        return
    with path.open(newline="") as handle:
        rows = [row for row in csv.DictReader(handle) if int(row["timesteps"]) <= max_timesteps]
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=CURVE_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


class TqdmProgressCallback(BaseCallback):
    """Progress bar over ``total_timesteps`` (shows the latest evaluation posterior mass).

    Args:
        total_timesteps: Target timestep count of the whole run.
        disable: No bar (e.g. not a terminal).
    """

    def __init__(self, total_timesteps: int, disable: bool = False) -> None:
        super().__init__()
        self.total_timesteps = int(total_timesteps)
        self.disable = disable
        self.bar: Any = None

    def _on_training_start(self) -> None:
        self.bar = tqdm(
            total=self.total_timesteps,
            initial=min(self.num_timesteps, self.total_timesteps),
            unit="step",
            dynamic_ncols=True,
            disable=self.disable,
        )

    def _on_step(self) -> bool:
        if self.bar is not None:
            self.bar.update(max(0, min(self.num_timesteps, self.total_timesteps) - self.bar.n))
        return True

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class PeriodicEvaluationCallback(BaseCallback):
    """Seeded evaluation episodes every ``eval_freq`` timesteps -> TensorBoard and CSV.

    Args:
        make_env: Builds the real parallel environment (called once, lazily).
        seeds: Episode seeds (the same every evaluation, so the curve is comparable).
        eval_freq: Timesteps between evaluations (> 0); also one at the end of training.
        curve_path: CSV file the rows are appended to (header written when new).
        on_result: Optional ``f(timesteps, summary)`` (e.g. to print or update a bar).
    """

    def __init__(
        self,
        make_env: Callable[[], Any],
        seeds: Sequence[int],
        eval_freq: int,
        curve_path: Path,
        on_result: Callable[[int, dict[str, float]], None] | None = None,
    ) -> None:
        super().__init__()
        if int(eval_freq) < 1:
            raise ValueError(f"eval_freq must be >= 1, got {eval_freq}")
        self.make_env = make_env
        self.seeds = [int(s) for s in seeds]
        self.eval_freq = int(eval_freq)
        self.curve_path = Path(curve_path)
        self.on_result = on_result
        self.env: Any = None
        self.last_evaluated = -1
        self.start_time = time.perf_counter()
        self.last_summary: dict[str, float] | None = None

    def _on_training_start(self) -> None:
        self.last_evaluated = (self.num_timesteps // self.eval_freq) * self.eval_freq

    def _on_rollout_start(self) -> None:
        # Evaluate between rollouts, after the policy update on the data collected so far (for
        # PPO a check inside the rollout would see the parameters before its last update).
        if self.num_timesteps - self.last_evaluated >= self.eval_freq:
            self.evaluate()

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self.num_timesteps != self.last_evaluated:
            self.evaluate()

    def evaluate(self) -> dict[str, float]:
        """Run the episodes now, log and append one CSV row; returns the summary."""
        if self.env is None:
            self.env = self.make_env()
        policy = TrainedPolicy(self.model, deterministic=True)
        summary = evaluate_policy(policy, self.env, self.seeds).summary()
        for key, value in summary.items():
            self.logger.record(f"eval/{key}", value)
        self.logger.dump(self.num_timesteps)
        row = {
            "timesteps": self.num_timesteps,
            **summary,
            "n_episodes": len(self.seeds),
            "wall_seconds": round(time.perf_counter() - self.start_time, 3),
        }
        new_file = not self.curve_path.is_file()
        with self.curve_path.open("a", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=CURVE_COLUMNS)
            if new_file:
                writer.writeheader()
            writer.writerow(row)
        self.last_evaluated = self.num_timesteps
        self.last_summary = summary
        if self.on_result is not None:
            self.on_result(self.num_timesteps, summary)
        return summary


class PruningCheckpointCallback(CheckpointCallback):
    """``CheckpointCallback`` keeping only the newest replay buffer (models are all kept)."""

    def _on_step(self) -> bool:
        result = super()._on_step()
        if self.save_replay_buffer and self.n_calls % self.save_freq == 0:
            buffers = []
            for path in Path(self.save_path).glob("*_replay_buffer_*_steps.pkl"):
                match = _REPLAY_PATTERN.search(path.name)
                if match:
                    buffers.append((int(match.group(1)), path))
            for _, path in sorted(buffers)[:-1]:
                path.unlink(missing_ok=True)
        return result
