"""``infoseek train``: parameter-shared RL training of one policy for every agent.

Example (PPO on the default bearings-only scenario, 4 airplanes)::

    infoseek train --algo ppo --env bearings_v0 --agents 4 --timesteps 1000000 --out runs/ppo

The run directory ``--out`` receives ``model.zip`` and ``config.json`` (what
``infoseek bench --policy DIR/model.zip`` and :func:`infoseek.baselines.load_policy` read),
``eval.csv`` (the training curve: mean entropy reduction and posterior mass of seeded evaluation
episodes every ``--eval-freq`` timesteps), ``checkpoints/`` and ``tb/`` (TensorBoard:
``tensorboard --logdir DIR/tb``). A timestep is one agent transition (an episode of 60 steps
with 4 agents is 240 timesteps).

**Resuming:** rerun the same command (same ``--out``, algorithm, environment, agents, action type
and environment keywords) after an interruption, or with a larger ``--timesteps``, and training
continues from the newest checkpoint (or ``model.zip``) with its timestep count and its
hyperparameters (a ``--hyper`` value that differs from the saved run's is refused); the rows of
``eval.csv`` after that count are dropped. Every ``--hyper`` value is type- and range-checked
before anything is written. Ctrl-C exits with code 130 and keeps the checkpoints.

**Imitation** (``--algo dagger``): behaviour cloning of an MI planner (``--expert``, default
``pairwise``) and then DAgger iterations, into the same run-directory layout
(:mod:`infoseek.baselines.imitation`)::

    infoseek train --algo dagger --env bearings_v0 --agents 4 --out runs/dagger

``--timesteps`` does not apply; the amount of data is ``--iterations``, ``--episodes`` and
``--episode-steps``. The observation gains the belief-moment block (``belief_moments=true``)
unless ``--env-kwarg belief_moments=false``. **Fine-tuning**: ``--algo ppo --init
DIR/model.zip`` starts PPO from the weights of that model (its observation and action spaces
must be this run's).

Requires the optional RL dependencies (``pip install 'infoseek[rl]'``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from infoseek.envs import registry
from infoseek.experiments.arguments import (
    add_environment_overrides,
    check_seed,
    check_writable_directory,
    environment_kwargs,
    key_value,
)

if TYPE_CHECKING:
    from infoseek.baselines.training import TrainingConfig, TrainingResult

__all__ = ["add_train_arguments", "run_train"]

#: Exit code of an interrupted (Ctrl-C) run (the checkpoints are kept; a rerun resumes).
EXIT_INTERRUPTED = 130


def add_train_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek train``."""
    _add_run_arguments(parser)
    _add_space_arguments(parser)
    add_environment_overrides(parser)
    _add_training_arguments(parser)
    _add_imitation_arguments(parser)


def _add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """What is trained, for how long, where to, and in how many environment copies."""
    parser.add_argument(
        "--algo",
        choices=("ppo", "sac", "td3", "dagger"),
        default="ppo",
        help="algorithm (default ppo; dagger: imitation of an MI planner)",
    )
    parser.add_argument(
        "--env", default="bearings_v0", choices=sorted(registry), help="environment id"
    )
    parser.add_argument("--agents", type=int, default=4, help="number of agents (default 4)")
    parser.add_argument(
        "--timesteps",
        type=int,
        default=None,
        help="total agent transitions to train for (including resumed ones; ppo/sac/td3)",
    )
    parser.add_argument("--out", type=Path, required=True, help="run directory (resumable)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument(
        "--n-envs", type=int, default=2, help="environment copies trained on (default 2)"
    )
    parser.add_argument(
        "--num-cpus",
        type=int,
        default=0,
        help="worker processes stepping the copies (default 0: in this process)",
    )


def _add_space_arguments(parser: argparse.ArgumentParser) -> None:
    """The policy's action space and the observation features its network reads."""
    parser.add_argument(
        "--action-type",
        choices=("continuous", "discrete"),
        default="continuous",
        help="action space (sac/td3: continuous only)",
    )
    parser.add_argument(
        "--features",
        choices=("egocentric", "scaled"),
        default="egocentric",
        help="observation features inside the network: scaled observation plus body-frame "
        "geometry (default), or the scaled observation only",
    )


def _add_training_arguments(parser: argparse.ArgumentParser) -> None:
    """Hyperparameters, evaluations, checkpoints, threads, progress and initial weights."""
    parser.add_argument(
        "--hyper",
        type=key_value,
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="algorithm hyperparameter override, e.g. n_steps=240 or net_arch=[64,64]",
    )
    parser.add_argument(
        "--eval-freq",
        type=int,
        default=20_000,
        help="timesteps between evaluations (0: only at the end; default 20000)",
    )
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=None,
        help="seeded episodes per evaluation (default 5; dagger: 50)",
    )
    parser.add_argument(
        "--checkpoint-freq",
        type=int,
        default=50_000,
        help="timesteps between checkpoints (0: none; default 50000)",
    )
    parser.add_argument(
        "--torch-threads", type=int, default=1, help="torch CPU threads (default 1)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--init", type=Path, default=None, help="start from this model's weights (ppo only)"
    )


def _add_imitation_arguments(parser: argparse.ArgumentParser) -> None:
    """The group of options that only ``--algo dagger`` reads."""
    imitation = parser.add_argument_group("imitation (--algo dagger)")
    imitation.add_argument(
        "--expert", default="pairwise", help="planner imitated (default pairwise)"
    )
    imitation.add_argument(
        "--iterations", type=int, default=8, help="DAgger iterations after cloning (default 8)"
    )
    imitation.add_argument(
        "--episodes", type=int, default=48, help="labelled episodes per iteration (default 48)"
    )
    imitation.add_argument(
        "--episode-steps", type=int, default=40, help="steps per labelled episode (default 40)"
    )
    imitation.add_argument(
        "--epochs", type=int, default=20, help="passes over the labelled set per iteration"
    )


def run_train(args: argparse.Namespace) -> int:
    """Train (or resume) the run described by ``args``; returns the exit code.

    Args:
        args: The parsed options of ``infoseek train``.

    Raises:
        ValueError: invalid arguments or an incompatible existing run directory.
    """
    try:
        from infoseek.baselines.training import train
    except ImportError as error:
        raise ValueError(
            f"infoseek train needs the optional RL dependencies (pip install 'infoseek[rl]'): "
            f"{error}"
        ) from None

    check_writable_directory(args.out)
    check_seed(args.seed)
    env_kwargs = environment_kwargs(args)
    if args.algo == "dagger":
        return _run_imitation(args, env_kwargs)
    config = _training_config(args, env_kwargs)
    if config.init_from is not None:
        from infoseek.baselines.training import check_initial_model

        check_initial_model(config)
    print(
        f"train {config.algo} on {config.env_id} ({config.n_agents} agents, "
        f"{config.action_type} actions), {config.timesteps} timesteps, seed {config.seed} "
        f"-> {args.out}",
        flush=True,
    )
    try:
        result = train(
            config, args.out, progress=not args.no_progress, on_evaluation=_print_evaluation
        )
    except KeyboardInterrupt:
        print(
            f"infoseek train: interrupted; checkpoints are in {args.out}, rerun the same "
            "command to resume",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    _print_training_result(result, config.timesteps)
    return 0


def _hyperparameters(pairs: Sequence[tuple[str, object]]) -> dict[str, object]:
    """The ``--hyper KEY=VALUE`` overrides (``(key, value)`` pairs) as a dictionary; a key may
    repeat with the same value, not with another (ValueError)."""
    hyper: dict[str, object] = {}
    for key, value in pairs:
        if key in hyper and hyper[key] != value:
            raise ValueError(f"--hyper {key} given twice ({hyper[key]!r} and {value!r})")
        hyper[key] = value
    return hyper


def _training_config(args: argparse.Namespace, env_kwargs: dict[str, object]) -> TrainingConfig:
    """The RL run (``ppo``/``sac``/``td3``) that ``args`` describe, its options checked."""
    from infoseek.baselines.training import TrainingConfig

    if args.timesteps is None:
        raise ValueError(f"--timesteps is required with --algo {args.algo}")
    hyper = _hyperparameters(args.hyper)
    if args.torch_threads is not None and args.torch_threads < 1:
        raise ValueError(f"--torch-threads must be >= 1, got {args.torch_threads}")
    return TrainingConfig(
        algo=args.algo,
        env_id=args.env,
        n_agents=args.agents,
        action_type=args.action_type,
        timesteps=args.timesteps,
        seed=args.seed,
        n_envs=args.n_envs,
        num_cpus=args.num_cpus,
        env_kwargs=env_kwargs,
        hyperparameters=hyper,
        eval_freq=args.eval_freq,
        eval_episodes=5 if args.eval_episodes is None else args.eval_episodes,
        checkpoint_freq=args.checkpoint_freq,
        torch_threads=args.torch_threads,
        features=args.features,
        init_from=None if args.init is None else str(args.init),
    )


def _print_evaluation(timesteps: int, summary: dict[str, float]) -> None:
    """One line per evaluation during training."""
    print(
        f"  eval @ {timesteps}: entropy reduction {summary['mean_entropy_reduction']:.3f}, "
        f"final posterior mass {summary['mean_final_posterior_mass']:.3f}, "
        f"mean posterior mass {summary['mean_posterior_mass']:.3f}",
        flush=True,
    )


def _print_training_result(result: TrainingResult, timesteps: int) -> None:
    """What a finished (or already complete) run of ``timesteps`` timesteps resumed and wrote."""
    if result.resumed_from is not None:
        print(f"resumed from {result.resumed_from} at {result.start_timesteps} timesteps")
    if result.start_timesteps >= timesteps and result.last_evaluation is None:
        print(f"{result.model_path} already has {result.timesteps} timesteps; nothing to do")
    print(f"wrote {result.model_path} ({result.timesteps} timesteps, {result.wall_seconds:.1f} s)")
    print(f"wrote {result.config_path}")
    print(f"training curve: {result.curve_path}")


def _run_imitation(args: argparse.Namespace, env_kwargs: dict[str, object]) -> int:
    """``infoseek train --algo dagger`` (module docstring)."""
    from infoseek.baselines.imitation import ImitationConfig, train_imitation

    if args.hyper or args.init is not None or args.timesteps is not None:
        raise ValueError("--hyper, --init and --timesteps do not apply to --algo dagger")
    if args.action_type != "continuous":
        raise ValueError("--algo dagger trains continuous actions (the planners' controls)")
    config = ImitationConfig(
        env_id=args.env,
        n_agents=args.agents,
        expert=args.expert,
        iterations=args.iterations,
        episodes_per_iteration=args.episodes,
        episode_steps=args.episode_steps,
        epochs=args.epochs,
        features=args.features,
        seed=args.seed,
        num_cpus=args.num_cpus,
        eval_episodes=50 if args.eval_episodes is None else args.eval_episodes,
        env_kwargs={"belief_moments": True, **env_kwargs},
    )
    config.check_environment()
    print(
        f"train dagger on {config.env_id} ({config.n_agents} agents), expert {config.expert}, "
        f"{config.iterations} iterations x {config.episodes_per_iteration} episodes, seed "
        f"{config.seed} -> {args.out}",
        flush=True,
    )

    def report(row: Mapping[str, float]) -> None:
        print(
            f"  iteration {int(row['iteration'])}: {int(row['labelled_states'])} labelled "
            f"states, fit loss {row['fit_loss']:.4f}, final posterior mass "
            f"{row['mean_final_posterior_mass']:.3f}, mean posterior mass "
            f"{row['mean_posterior_mass']:.3f} ({row['wall_seconds']:.0f} s)",
            flush=True,
        )

    try:
        result = train_imitation(config, args.out, on_iteration=report)
    except KeyboardInterrupt:
        print("infoseek train: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    print(
        f"wrote {result.model_path} ({result.labelled_states} labelled states, "
        f"{result.wall_seconds:.1f} s)"
    )
    print(f"wrote {result.config_path}")
    print(f"training curve: {result.curve_path}")
    return 0
