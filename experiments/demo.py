"""``infoseek demo``: one search episode on embedded defaults, printed and drawn.

The defaults are the paper's bearings-only scenario (section IV.A): four airplanes, 2000
particles per vehicle, the pairwise-node planner (eq. 22) with the decentralised penalty method
(section III.D). Each step prints the posterior mass within ``localization_radius`` of agent 0's
MMSE estimate (the metric of the paper's Fig. 1), the estimation error against the true target
(read through the evaluation accessor, never shown to the planner), the belief entropy and the
planning time, above a progress bar with the time left. Frames rendered by the environment are
written as an animated GIF, and the last frame as a PNG (atomically); an interrupted run (Ctrl-C)
writes the frames it has and exits with status 130. Each frame is reduced to the GIF's 256-colour
palette on a worker thread while the episode goes on (PIL's own conversion, which it would
otherwise make when saving: the same file; PIL releases the GIL while it quantises).
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from infoseek.envs import registry
from infoseek.experiments.arguments import check_seed, check_writable_directory
from infoseek.experiments.environments import make_env
from infoseek.experiments.policies import PLANNER_NAMES, make_policy
from infoseek.experiments.progress import progress_bar


def add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek demo``."""
    parser.add_argument(
        "--env", default="bearings_v0", choices=sorted(registry), help="environment id"
    )
    parser.add_argument(
        "--planner", default="pairwise", choices=PLANNER_NAMES, help="scripted planner to run"
    )
    parser.add_argument("--agents", type=int, default=4, help="number of vehicles")
    parser.add_argument("--particles", type=int, default=2000, help="particles per vehicle belief")
    parser.add_argument("--steps", type=int, default=None, help="episode length (env default)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the episode and the planner")
    parser.add_argument(
        "--out", type=Path, default=None, help="output folder (default infoseek-out/)"
    )
    parser.add_argument("--fps", type=float, default=4.0, help="frames per second of the GIF")
    parser.add_argument(
        "--no-progress",
        dest="progress",
        action="store_false",
        help="no progress bar (default: on a terminal)",
    )


def run_demo(args: argparse.Namespace) -> int:
    """Run the demo episode described by ``args``; returns the exit code.

    Args:
        args: The parsed options of ``infoseek demo``.
    """
    _check_arguments(args)
    out = args.out if args.out is not None else Path("infoseek-out")
    check_writable_directory(out)
    env = make_env(args.env, **_environment_kwargs(args))
    observations, infos = env.reset(seed=args.seed)
    policy = make_policy(args.planner, env, seed=args.seed)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"demo-{args.env}-{args.planner}-{args.agents}agents-seed{args.seed}"

    frames = _GifFrames(env.render())
    print(
        f"{args.env}: {args.agents} x {args.planner}, {args.particles} particles, seed {args.seed}"
    )
    mass_header = f"mass<={env.unwrapped.config.localization_radius:g}"
    print(f"{'step':>4} {mass_header:>9} {'error':>8} {'entropy':>8} {'plan ms':>8}", flush=True)
    bar = progress_bar(
        int(env.unwrapped.config.max_cycles), "demo", None if args.progress else False, unit="step"
    )
    interrupted = False
    try:
        _play(env, policy, observations, infos, frames, bar)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
        env.close()

    gif_path = out / f"{stem}.gif"
    png_path = out / f"{stem}.png"
    duration_ms = int(round(1000.0 / args.fps))
    _save_atomically(frames.images(), gif_path, format="GIF", duration=duration_ms, loop=0)
    _save_atomically([_image(frames.last)], png_path, format="PNG")
    if interrupted:
        print(f"interrupted after {len(frames) - 1} step(s); the frames so far are written")
    print(f"wrote {gif_path}")
    print(f"wrote {png_path}")
    return 130 if interrupted else 0


def _check_arguments(args: argparse.Namespace) -> None:
    """Refuse a non-positive fleet, frame rate or particle count, and a bad seed."""
    if args.agents < 1:
        raise ValueError(f"--agents must be >= 1, got {args.agents}")
    if not args.fps > 0:
        raise ValueError(f"--fps must be > 0, got {args.fps}")
    if args.particles < 1:
        raise ValueError(f"--particles must be >= 1, got {args.particles}")
    check_seed(args.seed)


def _environment_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of the demo's environment (rendered to RGB arrays); ``--steps`` checked."""
    kwargs = {"n_agents": args.agents, "n_particles": args.particles, "render_mode": "rgb_array"}
    if args.steps is not None:
        if args.steps < 1:
            raise ValueError(f"--steps must be >= 1, got {args.steps}")
        kwargs["max_cycles"] = args.steps
    return kwargs


class _GifFrames:
    """The demo's frames, each reduced to a 256-colour palette on one worker thread as it
    arrives (``Image.convert("P", palette=ADAPTIVE)``, what PIL does to RGB frames it saves as a
    GIF: the file is the same), so that the reduction overlaps the episode.

    Args:
        first: The first ``(H, W, 3)`` uint8 RGB frame.

    Attributes:
        last: The last RGB frame appended.
    """

    last: np.ndarray

    def __init__(self, first: np.ndarray) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="demo-gif")
        self._pending: list[Future[Any]] = []
        self.append(first)

    def __len__(self) -> int:
        return len(self._pending)

    def append(self, frame: np.ndarray) -> None:
        """Add one ``(H, W, 3)`` uint8 RGB frame."""
        self.last = frame
        self._pending.append(self._pool.submit(_palette_image, frame))

    def images(self) -> list[Any]:
        """Every frame as a palette image, in order (waits for the worker; closes it)."""
        try:
            return [pending.result() for pending in self._pending]
        finally:
            self._pool.shutdown()


def _image(frame: np.ndarray) -> Any:
    from PIL import Image

    return Image.fromarray(frame)


def _palette_image(frame: np.ndarray) -> Any:
    from PIL import Image

    return _image(frame).convert("P", palette=Image.Palette.ADAPTIVE)


def _play(
    env: Any,
    policy: Any,
    observations: dict[str, Any],
    infos: dict[str, Any],
    frames: _GifFrames,
    bar: Any,
) -> None:
    """Step ``env`` with ``policy`` from ``observations`` and ``infos`` to the end of the
    episode: one line per step written above ``bar``, each rendered frame appended to
    ``frames`` (so an interrupted episode keeps the frames it has)."""
    step = 0
    while env.agents:
        start = time.perf_counter()
        actions = policy.act(observations, infos)
        plan_ms = 1e3 * (time.perf_counter() - start)
        observations, _, _, _, infos = env.step(actions)
        step += 1
        bar.write(_step_line(env, step, infos, plan_ms))
        frames.append(env.render())
        bar.update(1)


def _step_line(env: Any, step: int, infos: dict[str, Any], plan_ms: float) -> str:
    """Step, agent 0's posterior mass (from its ``infos``), its MMSE estimate's error against
    the true target, its belief entropy and the planning time."""
    first = env.possible_agents[0]
    truth = env.unwrapped.true_target()
    info = infos[first]
    view = env.unwrapped.belief(first)
    estimate = np.average(view.particles[:, :2], weights=view.weights, axis=0)
    error = float(np.hypot(*(estimate - truth[:2])))
    return (
        f"{step:>4} {info['posterior_mass']:>9.3f} {error:>8.2f} "
        f"{info['entropy']:>8.3f} {plan_ms:>8.1f}"
    )


def _save_atomically(images: list[Any], path: Path, format: str, **options: Any) -> None:
    """Save PIL ``images`` to a temporary file, then rename it to ``path``: never a partial
    image. ``format`` and ``options`` (animation settings) go to ``Image.save``."""
    tmp = path.with_name(f".{path.name}.tmp")
    if len(images) > 1:
        options = {**options, "save_all": True, "append_images": images[1:]}
    images[0].save(tmp, format=format, **options)
    os.replace(tmp, path)
