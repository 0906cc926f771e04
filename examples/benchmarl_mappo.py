"""MAPPO (or IPPO) on an infoseek environment through BenchMARL.

The recipe:

1. ``InfoseekTask.BEARINGS_V0.get_task(env_kwargs)`` (:mod:`infoseek.baselines.benchmarl_task`)
   is the BenchMARL task; its config is the environment's keyword arguments. It wraps the
   parallel environment with TorchRL's ``PettingZooWrapper(..., return_state=True)`` and
   declares ``env.state()`` as the task's state.
2. ``MappoConfig`` / ``IppoConfig`` and ``MlpConfig`` come from BenchMARL's own YAML defaults.
3. ``ExperimentConfig`` is shrunk to this machine: CPU only, no loggers, no evaluation, no
   rendering (evaluation videos are written with torchvision; the task also declares no
   renderer), no checkpoints, a few on-policy iterations.
4. ``Experiment(...).run()`` trains; ``experiment.total_frames`` and ``experiment.mean_return``
   report what happened.

With MAPPO the critic reads the centralised state (its input keys are ``("state",)``), with
IPPO each agent's own observation; :func:`train` returns those keys so the difference is
visible. ``--smoke`` runs two iterations of 80 frames; the default run is 20 iterations of
1200 frames (about 2.5 minutes on two loaded cores).

Run: ``python examples/benchmarl_mappo.py [--smoke] [--algorithm ippo] [--env beacon_v0]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import torch
from benchmarl.algorithms import IppoConfig, MappoConfig
from benchmarl.experiment import Experiment, ExperimentConfig
from benchmarl.models.mlp import MlpConfig

from infoseek.baselines.benchmarl_task import GROUP, InfoseekTask


@dataclass(frozen=True)
class BenchmarlRun:
    """What one BenchMARL training run did."""

    algorithm: str
    iterations: int
    frames: int
    mean_return: float
    state_shape: tuple[int, ...]
    critic_in_keys: tuple[str | tuple[str, ...], ...]
    seconds: float

    @classmethod
    def from_experiment(
        cls, experiment: Experiment, algorithm: str, seconds: float
    ) -> BenchmarlRun:
        """What a finished experiment did: iterations, frames, last mean return, the task's
        state shape and the critic's input keys.

        Args:
            experiment: The BenchMARL experiment, after ``run()``.
            algorithm: Its algorithm (``"mappo"`` or ``"ippo"``).
            seconds: The wall time of its construction and run.
        """
        state_spec = experiment.state_spec
        return cls(
            algorithm=algorithm,
            iterations=int(experiment.n_iters_performed),
            frames=int(experiment.total_frames),
            mean_return=float(experiment.mean_return),
            state_shape=tuple(state_spec["state"].shape) if state_spec is not None else (),
            critic_in_keys=tuple(experiment.losses[GROUP].critic_network.in_keys),
            seconds=seconds,
        )


def experiment_config(
    *,
    iterations: int,
    frames_per_batch: int,
    n_envs: int,
    minibatch_size: int,
    minibatch_iters: int,
    save_folder: Path,
    continuous_actions: bool = True,
) -> ExperimentConfig:
    """BenchMARL's default experiment config, reduced to a short on-policy CPU run."""
    config = ExperimentConfig.get_from_yaml()
    config.sampling_device = "cpu"
    config.train_device = "cpu"
    config.buffer_device = "cpu"
    config.prefer_continuous_actions = continuous_actions
    config.max_n_iters = iterations
    config.max_n_frames = None
    config.on_policy_collected_frames_per_batch = frames_per_batch
    config.on_policy_n_envs_per_worker = n_envs
    config.on_policy_minibatch_size = minibatch_size
    config.on_policy_n_minibatch_iters = minibatch_iters
    config.evaluation = False
    config.render = False
    config.loggers = []
    config.create_json = False
    config.checkpoint_interval = 0
    config.checkpoint_at_end = False
    config.save_folder = str(save_folder)
    return config


def train(
    env_id: str = "bearings_v0",
    algorithm: str = "mappo",
    *,
    n_agents: int = 2,
    n_particles: int = 200,
    max_cycles: int = 20,
    iterations: int = 20,
    frames_per_batch: int = 1200,
    n_envs: int = 4,
    minibatch_size: int = 300,
    minibatch_iters: int = 10,
    continuous_actions: bool = True,
    seed: int = 0,
    save_folder: Path | None = None,
) -> BenchmarlRun:
    """Train ``algorithm`` (``"mappo"`` or ``"ippo"``) on ``env_id`` with BenchMARL.

    ``frames_per_batch`` must be a multiple of ``n_envs``; one frame is one environment step
    of the whole team. ``save_folder`` (None: a temporary folder) receives BenchMARL's
    experiment folder.
    """
    algorithm_configs = {"mappo": MappoConfig, "ippo": IppoConfig}
    if algorithm not in algorithm_configs:
        raise ValueError(f"algorithm must be one of {sorted(algorithm_configs)}, got {algorithm!r}")
    task = InfoseekTask[env_id.upper()].get_task(
        {"n_agents": n_agents, "n_particles": n_particles, "max_cycles": max_cycles}
    )
    with tempfile.TemporaryDirectory(prefix="infoseek-benchmarl-") as scratch:
        folder = Path(save_folder) if save_folder is not None else Path(scratch)
        folder.mkdir(parents=True, exist_ok=True)
        config = experiment_config(
            iterations=iterations,
            frames_per_batch=frames_per_batch,
            n_envs=n_envs,
            minibatch_size=minibatch_size,
            minibatch_iters=minibatch_iters,
            save_folder=folder,
            continuous_actions=continuous_actions,
        )
        start = time.perf_counter()
        experiment = Experiment(
            task=task,
            algorithm_config=algorithm_configs[algorithm].get_from_yaml(),
            model_config=MlpConfig.get_from_yaml(),
            critic_model_config=MlpConfig.get_from_yaml(),
            seed=seed,
            config=config,
        )
        experiment.run()
        seconds = time.perf_counter() - start
    return BenchmarlRun.from_experiment(experiment, algorithm, seconds)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="two iterations of 80 frames")
    parser.add_argument("--algorithm", choices=["mappo", "ippo"], default="mappo")
    parser.add_argument("--env", default="bearings_v0", choices=["bearings_v0", "beacon_v0"])
    parser.add_argument("--discrete", action="store_true", help="discrete actions")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    continuous = not args.discrete
    if args.smoke:
        run = train(
            args.env,
            args.algorithm,
            iterations=2,
            frames_per_batch=80,
            n_envs=2,
            minibatch_size=40,
            minibatch_iters=2,
            continuous_actions=continuous,
            seed=args.seed,
        )
    else:
        run = train(args.env, args.algorithm, continuous_actions=continuous, seed=args.seed)
    print(
        f"{run.algorithm} on {args.env}: {run.iterations} iterations, {run.frames} frames in "
        f"{run.seconds:.1f} s; mean return of the last batch {run.mean_return:.3f}; "
        f"state {run.state_shape}; critic reads {list(run.critic_in_keys)}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
