"""The ``infoseek`` command.

Subcommands:

* ``infoseek demo``: the main job on its embedded defaults (bearings-only search, 4 airplanes,
  2000 particles each, the pairwise-node planner); prints one line per step and writes an animated
  GIF and a final PNG of the search.
* ``infoseek timing``: the speed benchmarks of the planners issue (mutual information, planning
  steps, environment steps), printed as a table with the machine they ran on.
* ``infoseek bench``: Monte Carlo trials of (environment, planner, number of agents) over seeds,
  every finished trial appended to a resumable results store
  (:mod:`infoseek.experiments.bench`, :mod:`infoseek.experiments.store`), then a summary table.
* ``infoseek plot DIR``: the paper's Fig. 1 from a results store
  (:mod:`infoseek.experiments.plot`).
* ``infoseek reproduce STUDY``: the trials, figures and results page of a study
  (:mod:`infoseek.experiments.reproduce`, the studies in :mod:`infoseek.experiments.studies`).
* ``infoseek page STUDY``: rewrite a study's results page from its stored results
  (:mod:`infoseek.experiments.pages`).
* ``infoseek claims DIR``: paired statistical tests of the paper's Fig. 1 claims on stored
  trials (:mod:`infoseek.experiments.studies.claims`).
* ``infoseek verify DIR``: rerun stored trials from their seeds and report the records the
  installed code does not reproduce (:mod:`infoseek.experiments.verify`); ``--integrity``
  checks every file of the store against its checksums instead
  (:mod:`infoseek.experiments.integrity`).
* ``infoseek migrate DIR``: bring a store to the current format: checksums recorded, trained
  policies' groups relabelled portably (:mod:`infoseek.experiments.policy_labels`); no trial
  is rerun and no number changes.
* ``infoseek train``: train one parameter-shared RL policy (PPO, SAC or TD3) on an environment's
  entropy-reduction reward (:mod:`infoseek.experiments.train`, needs the ``rl`` extra).

Errors in the arguments or the results directory (a damaged store included) print
``infoseek COMMAND: error: ...`` on stderr and make :func:`main` return 2; nothing already
stored is changed. Every command runs with one BLAS/OpenMP/torch thread unless
``INFOSEEK_THREADS`` says otherwise (:mod:`infoseek.experiments.threads`).
"""

from __future__ import annotations

import argparse
import signal
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from infoseek.experiments.arguments import (
    add_environment_overrides,
    check_results_directory,
    check_seed,
    check_writable_directory,
    check_writable_file,
    environment_kwargs,
    key_value,
)
from infoseek.experiments.commands import (
    EXIT_INTERRUPTED,
    add_execution_arguments,
    execution,
    run_plan,
)
from infoseek.experiments.demo import add_demo_arguments, run_demo
from infoseek.experiments.pages.command import add_page_arguments, run_page_command
from infoseek.experiments.policies import PLANNER_NAMES
from infoseek.experiments.reproduce import add_reproduce_arguments, run_reproduce_command
from infoseek.experiments.store import StoreWarning
from infoseek.experiments.studies.claims import add_claims_arguments, run_claims
from infoseek.experiments.threads import limited_threads
from infoseek.experiments.timing import add_timing_arguments, run_timing
from infoseek.experiments.train import add_train_arguments, run_train

__all__ = ["EXIT_INTERRUPTED", "build_parser", "main", "stop_on_signals"]


def _int_list(text: str) -> list[int]:
    """``"2,3,4"`` or ``"4"`` -> list of ints (argparse type)."""
    try:
        return [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected integers like 4 or 2,3,4, got {text!r}"
        ) from None


def add_bench_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek bench``."""
    parser.add_argument("--env", default="bearings_v0", help="environment id (default bearings_v0)")
    parser.add_argument(
        "--planner",
        action="append",
        default=None,
        help="scripted planner (repeatable; default pairwise): "
        + ", ".join(PLANNER_NAMES)
        + ", or package.module:factory",
    )
    parser.add_argument(
        "--policy",
        action="append",
        default=None,
        metavar="PATH",
        help="trained RL policy to benchmark (repeatable; needs infoseek.baselines.load_policy)",
    )
    parser.add_argument(
        "--agents",
        type=_int_list,
        nargs="+",
        action="extend",  # --agents 2 --agents 4 is --agents 2 4, not the last one alone
        default=None,
        help="agent counts, e.g. --agents 2 3 4 10 or --agents 2,3,4 (repeatable; default 4)",
    )
    parser.add_argument("--trials", type=int, default=100, help="trials per planner and count")
    parser.add_argument(
        "--steps", type=int, default=None, help="steps per trial (default: env's max_cycles)"
    )
    parser.add_argument("--seed", type=int, default=0, help="root seed of the run")
    add_environment_overrides(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="results directory (default infoseek-out/bench-ENV-seedSEED)",
    )
    add_execution_arguments(parser)


def run_bench_command(args: argparse.Namespace) -> int:
    """``infoseek bench``: run the missing trials, store them, print the summary."""
    from infoseek.experiments.bench import plan_bench

    if args.trials is not None and args.trials < 1:
        raise ValueError(f"--trials must be >= 1, got {args.trials}")
    if args.steps is not None and args.steps < 1:
        raise ValueError(f"--steps must be >= 1, got {args.steps}")
    check_seed(args.seed)
    env_kwargs = environment_kwargs(args)
    out = (
        args.out
        if args.out is not None
        else Path("infoseek-out") / f"bench-{args.env}-seed{args.seed}"
    )
    check_writable_directory(out)
    execution(args)
    plan = plan_bench(
        args.env,
        env_kwargs,
        planners=args.planner or ([] if args.policy else ["pairwise"]),
        policies=args.policy or [],
        agents=[n for group in (args.agents or [[4]]) for n in group],
        trials=args.trials,
        steps=args.steps,
        seed=args.seed,
        out=out,
    )
    return run_plan(plan, out, args)[0]


def add_plot_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek plot``."""
    parser.add_argument("directory", type=Path, help="results directory written by bench")
    parser.add_argument(
        "--out", type=Path, default=None, help="output stem (default DIRECTORY/fig1)"
    )


def run_plot_command(args: argparse.Namespace) -> int:
    """``infoseek plot DIR``: Fig. 1 (PNG and SVG) from a results store."""
    from infoseek.experiments.plot import plot_fig1_from_store

    check_results_directory(args.directory)
    stem = args.out if args.out is not None else args.directory / "fig1"
    check_writable_file(Path(f"{stem}.png"), "--out")
    paths = plot_fig1_from_store(args.directory, args.out)
    for path in paths:
        print(f"wrote {path}")
    return 0


def add_verify_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek verify``."""
    parser.add_argument("directory", type=Path, help="results directory of a bench/reproduce run")
    parser.add_argument(
        "--trials",
        type=int,
        default=None,
        help="rerun only trials 0..N-1 of every group (default: every stored trial)",
    )
    parser.add_argument(
        "--group",
        action="append",
        default=None,
        metavar="PLANNER/AGENTS",
        help="rerun only this group, e.g. --group single/4 (repeatable; default: all)",
    )
    parser.add_argument(
        "--integrity",
        action="store_true",
        help="check every file of the store against its checksums instead of rerunning "
        "trials (exit status 2 if any is damaged)",
    )
    add_execution_arguments(parser)


def _group(text: str) -> tuple[str, int]:
    planner, _, agents = text.rpartition("/")
    if not planner or not agents.isdigit():
        raise ValueError(f"--group must look like PLANNER/AGENTS (e.g. single/4), got {text!r}")
    return planner, int(agents)


def run_verify_command(args: argparse.Namespace) -> int:
    """``infoseek verify``: rerun stored trials; exit status 1 if any record is not reproduced."""
    from infoseek.experiments.verify import ATOL, RTOL, verify_store

    check_results_directory(args.directory)
    if args.integrity:
        if args.trials is not None or args.group is not None:
            raise ValueError(
                "--integrity checks the whole store; --trials/--group select "
                "trials to rerun: give one or the other"
            )
        return _check_integrity(args.directory)
    backend, workers = execution(args)
    groups = None if args.group is None else [_group(text) for text in args.group]
    result = verify_store(
        args.directory,
        trials=args.trials,
        groups=groups,
        backend=backend,
        workers=workers,
        address=args.address,
        progress=False if args.no_progress else None,
    )
    from infoseek.experiments.numerics import describe
    from infoseek.experiments.store import read_manifest

    stored = read_manifest(args.directory).get("numerics")
    current = describe()
    print(f"numerical environment: {_numerics_line(current)}")
    if stored is not None:  # compared on what the store recorded (older stores record less)
        recorded = {key: value for key, value in current.items() if key in stored}
        if _numerics_line(stored) != _numerics_line(recorded):
            print(f"  (the store was written under: {_numerics_line(stored)})")
    for key, comparison in result.differing.items():
        step = "" if comparison.first_step is None else f" from step {comparison.first_step}"
        print(f"{key}: diverged{step}; differs in {', '.join(comparison.fields)}")
    exact = result.checked - len(result.differing) - result.within_tolerance
    print(
        f"{result.checked} stored trial(s) rerun: {exact} reproduced exactly, "
        f"{result.within_tolerance} equal within tolerance (largest difference "
        f"{result.largest_noise:.1e}; rtol {RTOL:g}, atol {ATOL:g}), "
        f"{len(result.differing)} not reproduced by the installed code"
    )
    return 1 if result.differing else 0


def _check_integrity(directory: Path) -> int:
    """``infoseek verify --integrity``: every file against its checksums; exit status 2 and
    one line per damaged file if any."""
    from infoseek.experiments.integrity import check_integrity

    report = check_integrity(directory)
    for note in report.notes:
        print(f"note: {note}")
    print(report.summary())
    for problem in report.problems:
        print(f"infoseek verify: error: {problem}", file=sys.stderr)
    return 2 if report.problems else 0


def add_migrate_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek migrate``."""
    parser.add_argument("directory", type=Path, help="results directory of a bench/reproduce run")
    parser.add_argument(
        "--relocate",
        type=key_value,
        action="append",
        default=[],
        metavar="OLD=NEW",
        help="the store was written in checkout OLD: find its models under NEW (repeatable)",
    )


def run_migrate_command(args: argparse.Namespace) -> int:
    """``infoseek migrate DIR``: checksums recorded (format 3), absolute policy labels made
    portable; no trial rerun, no number changed."""
    from infoseek.experiments.policy_labels import migration
    from infoseek.experiments.store import ResultsStore, read_manifest

    check_results_directory(args.directory)
    manifest = read_manifest(args.directory)
    relocate = {str(old): str(new) for old, new in args.relocate}
    with ResultsStore(args.directory, manifest["config"]) as store:
        labels = sorted({key.rsplit("/agents=", 1)[0] for key in store.keys})
        changes = migration(labels, args.directory, relocate)
        rows = store.relabel(changes)
    for old, new in changes.items():
        print(f"{old} -> {new}")
    print(f"{args.directory}: format 3 with checksums; {rows} trial(s) relabelled")
    return 0


def _numerics_line(numerics: dict[str, Any]) -> str:
    blas = ", ".join(f"{b.get('library')} {b.get('kernel')}" for b in numerics.get("blas", []))
    simd = "/".join(numerics.get("numpy_simd", [])) or "baseline"
    line = f"NumPy {numerics.get('numpy')} SIMD {simd}; BLAS {blas or 'none loaded'}"
    numba = numerics.get("numba")  # stores written before the compiled kernels have none
    if numba is not None:
        line += f"; numba {numba.get('numba')} target {numba.get('cpu_name')}"
    if "scipy" in numerics:  # recorded since the beacon kernel calls SciPy's erf
        line += f"; SciPy {numerics['scipy']}; C library {numerics.get('libc')}"
    return line


_AddArguments = Callable[[argparse.ArgumentParser], None]
_Handler = Callable[[argparse.Namespace], int]


def _subcommands() -> list[tuple[str, str, _AddArguments, _Handler]]:
    """Each subcommand's name, one-line help, option adder and handler, in the order
    ``infoseek --help`` lists them.

    The functions are looked up when the parser is built, not when this module is imported,
    so a handler replaced on this module (as tests do) is the one that runs.
    """
    return [
        (
            "demo",
            "run one search episode and write a GIF and a PNG of it",
            add_demo_arguments,
            run_demo,
        ),
        (
            "timing",
            "measure mutual-information, planning and env-step speed",
            add_timing_arguments,
            run_timing,
        ),
        (
            "bench",
            "Monte Carlo trials of planners over seeds into a resumable results store",
            add_bench_arguments,
            run_bench_command,
        ),
        (
            "plot",
            "the paper's Fig. 1 from a bench results directory",
            add_plot_arguments,
            run_plot_command,
        ),
        (
            "reproduce",
            "run a study (the paper's Fig. 1 or 2, beacon, ablation) and draw its figures",
            add_reproduce_arguments,
            run_reproduce_command,
        ),
        (
            "page",
            "rewrite a study's results page from its stored results (runs no trial)",
            add_page_arguments,
            run_page_command,
        ),
        (
            "claims",
            "paired statistical tests of the paper's Fig. 1 claims on stored trials",
            add_claims_arguments,
            run_claims,
        ),
        (
            "verify",
            "rerun stored trials from their seeds and compare them with their records",
            add_verify_arguments,
            run_verify_command,
        ),
        (
            "train",
            "train a parameter-shared RL policy (PPO/SAC/TD3) on the entropy reward",
            add_train_arguments,
            run_train,
        ),
        (
            "migrate",
            "bring a results store to the current format (checksums, portable policy labels)",
            add_migrate_arguments,
            run_migrate_command,
        ),
    ]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``infoseek`` command."""
    parser = argparse.ArgumentParser(
        prog="infoseek",
        description=(
            "Information-seeking mobile sensor networks (Hoffmann, Waslander & Tomlin 2006)."
        ),
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, help_text, add_arguments, handler in _subcommands():
        subparser = sub.add_parser(name, help=help_text)
        add_arguments(subparser)
        subparser.set_defaults(handler=handler)
    return parser


def _interrupt(signum: int, frame: object) -> None:
    """Turn SIGTERM into the Ctrl-C path (stored trials compacted, exit 130)."""
    raise KeyboardInterrupt


def stop_on_signals() -> None:
    """SIGINT and SIGTERM both stop a command the way Ctrl-C does, also in a background job
    (where a shell starts commands with SIGINT ignored) and under ``kill``, so a bench stopped
    either way writes its journal to a Parquet part before it exits."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _interrupt)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the process exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse: --help (0) or a usage error (2, message printed)
        return exit_.code if isinstance(exit_.code, int) else 2
    try:
        with limited_threads(), warnings.catch_warnings():
            warnings.simplefilter("always", StoreWarning)
            warnings.showwarning = _warning_printer(args.command)
            return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print(f"infoseek {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ImportError as error:
        missing = getattr(error, "name", None) or str(error)
        print(
            f"infoseek {args.command}: error: {missing} is not installed{_extra_hint(missing)}",
            file=sys.stderr,
        )
        return 2
    except (ValueError, TypeError, OSError) as error:
        print(f"infoseek {args.command}: error: {_one_line(error)}", file=sys.stderr)
        return 2


#: Top-level module -> the extra of infoseek that installs it.
_EXTRAS = {
    "stable_baselines3": "rl",
    "supersuit": "rl",
    "torch": "rl",
    "tensorboard": "rl",
    "ray": "distributed",
}


def _warning_printer(command: str) -> Any:
    """A ``warnings.showwarning`` that prints a store warning as one line on stderr."""
    default = warnings.showwarning

    def show(message: Any, category: type[Warning], *rest: Any, **kwargs: Any) -> None:
        if issubclass(category, StoreWarning):
            print(f"infoseek {command}: warning: {message}", file=sys.stderr)
        else:
            default(message, category, *rest, **kwargs)

    return show


def _extra_hint(module: str) -> str:
    extra = _EXTRAS.get(module.split(".")[0])
    return f"; install the '{extra}' extra: pip install 'infoseek[{extra}]'" if extra else ""


def _one_line(error: BaseException) -> str:
    text = str(error) if str(error) else type(error).__name__
    return " ".join(text.split())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
