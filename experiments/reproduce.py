"""``infoseek reproduce STUDY``: run a study's trials with its settings, then draw its figures.

Part of the command line's top layer: each study lives in :mod:`infoseek.experiments.studies`
(its plan, tables and figures); this module runs it. The studies:

* ``fig1``: the paper's Fig. 1 (:mod:`~infoseek.experiments.studies.fig1`);
* ``fig2``: the paper's Fig. 2, one episode (:mod:`~infoseek.experiments.studies.fig2`);
* ``beacon``: the beacon Monte Carlo study (:mod:`~infoseek.experiments.studies.beacon`);
* ``beacon_v1``: the same on ``beacon_v1``, paired trial by trial with ``beacon``, then why
  pairwise-node does or does not beat single-node there (the decisions study and the switched
  planners, :mod:`~infoseek.experiments.studies.beacon_mechanism`, with their default trial
  counts or ``--trials`` if smaller, and the same ``--steps`` / ``--particles``);
* ``ablation``: the Claim A ablation with the decisions study
  (:mod:`~infoseek.experiments.studies.ablation`, :mod:`~infoseek.experiments.studies.decisions`);
* ``grid_posterior``: the Fig. 1 store's episodes rerun beside an exact grid posterior
  (:mod:`~infoseek.experiments.studies.grid_posterior`);
* ``beacon_grid``: a beacon store's episodes rerun beside an exact 3-D grid posterior
  (:mod:`~infoseek.experiments.studies.beacon_grid`; ``--store`` and ``--group`` choose the
  store and its groups, default the committed beacon store's ``pairwise/4``);
* ``horizon``: the receding-horizon planner and the clairvoyant reference added to a Fig. 1
  store (:mod:`~infoseek.experiments.studies.horizon`; the Fig. 1 groups are run first, or
  resumed, since the study compares with them);
* ``learned``: policies trained by imitating the planners, five training seeds per setting,
  benchmarked against the planners (:mod:`~infoseek.experiments.studies.learned`; a seed whose
  run directory holds a model is not retrained).

Trial studies resume: a rerun with every trial stored only redraws. Every study ends by writing
its results page (``--page FILE``, default ``OUT/page.md``; :mod:`infoseek.experiments.pages`).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from infoseek.experiments.arguments import check_seed, check_writable_directory, check_writable_file
from infoseek.experiments.commands import add_execution_arguments, execution, run_plan
from infoseek.experiments.pages.fig2_record import write_fig2_record
from infoseek.experiments.pages.registry import MIN_PAGE_TRIALS, write_page
from infoseek.experiments.plot import plot_fig1_from_store
from infoseek.experiments.studies import (
    ablation,
    beacon_grid,
    beacon_mechanism,
    decisions,
    fig2,
    grid_posterior,
    learned,
)
from infoseek.experiments.studies.beacon import DEFAULT_V1_TRIALS, beacon_plan, beacon_v1_plan
from infoseek.experiments.studies.fig1 import fig1_plan
from infoseek.experiments.studies.horizon import horizon_plans

__all__ = ["STUDIES", "add_reproduce_arguments", "fig1_plan", "run_reproduce_command"]

#: The studies ``infoseek reproduce`` runs.
STUDIES = (
    "fig1",
    "fig2",
    "beacon",
    "beacon_v1",
    "ablation",
    "grid_posterior",
    "beacon_grid",
    "horizon",
    "learned",
)


def add_reproduce_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek reproduce``."""
    parser.add_argument(
        "figure",
        choices=STUDIES,
        help="which study: the paper's fig1 or fig2, the beacon Monte Carlo study (beacon_v0: "
        "beacon; beacon_v1, with why Claim A comes out as it does: beacon_v1), the Claim A "
        "ablation, the filter against an exact grid posterior (bearings: grid_posterior; "
        "beacon: beacon_grid), the receding-horizon planner "
        "and the clairvoyant reference added to a Fig. 1 store, or policies that imitate the "
        "planners (learned)",
    )
    parser.add_argument(
        "--trials",
        type=int,
        default=None,
        help="trials per curve (fig1: default 1000; beacon: default 500; beacon_v1: "
        f"{DEFAULT_V1_TRIALS}; ablation: 100; horizon: the committed counts)",
    )
    parser.add_argument(
        "--steps", type=int, default=None, help="steps per trial (default: the env's episode)"
    )
    parser.add_argument(
        "--particles", type=int, default=None, help="particles per belief (default: env's 2000)"
    )
    parser.add_argument("--seed", type=int, default=0, help="root seed")
    parser.add_argument(
        "--out", type=Path, default=None, help="output directory (default infoseek-out/FIGURE)"
    )
    parser.add_argument(
        "--page", type=Path, default=None, help="the results page to write (default OUT/page.md)"
    )
    parser.add_argument(
        "--store",
        type=Path,
        default=None,
        help="beacon_grid only: the store whose episodes are rerun (default "
        f"{beacon_grid.BEACON_STORE})",
    )
    parser.add_argument(
        "--group",
        action="append",
        default=None,
        metavar="PLANNER/N",
        help="beacon_grid only: a group of the store to rerun, repeatable (default "
        + ", ".join(f"{p}/{n}" for p, n in beacon_grid.DEFAULT_GROUPS)
        + ")",
    )
    parser.add_argument(
        "--halved-cells",
        action="store_true",
        help="beacon_grid only: the resolution check, every grid cell halved (8x the cells), "
        "into OUT/beacon_grid_halved.json",
    )
    add_execution_arguments(parser)


def run_reproduce_command(args: argparse.Namespace) -> int:
    """``infoseek reproduce STUDY``."""
    for option in ("trials", "steps", "particles"):
        value = getattr(args, option)
        if value is not None and value < 1:
            raise ValueError(f"--{option} must be >= 1, got {value}")
    check_seed(args.seed)
    out = args.out if args.out is not None else Path("infoseek-out") / args.figure
    check_writable_directory(out)
    page = args.page if args.page is not None else out / "page.md"
    check_writable_file(page, "--page")
    paged = args.figure == "fig2" or args.trials is None or args.trials >= MIN_PAGE_TRIALS
    if not paged:
        print(f"reproduce: no results page with --trials {args.trials} (its paired tests need")
        print(f"  at least {MIN_PAGE_TRIALS} trials per group)")
    code = _run_study(out, args)
    if code == 0 and paged:
        print(f"wrote {write_page(args.figure, out, page)}")
    return code


def _run_study(out: Path, args: argparse.Namespace) -> int:
    """Run the study ``args.figure`` into ``out``; returns the exit code."""
    if args.figure == "fig2":
        return _fig2(out, args)
    _, workers = execution(args)
    beacon_options = (args.store, args.group, args.halved_cells or None)
    if args.figure != "beacon_grid" and any(option is not None for option in beacon_options):
        raise ValueError("reproduce: --store/--group/--halved-cells only apply to beacon_grid")
    if args.figure == "beacon_grid":
        return _beacon_grid(out, args, workers)
    if args.figure == "grid_posterior":  # the Fig. 1 store's episodes beside an exact posterior
        if args.steps is not None or args.particles is not None or args.seed != 0:
            raise ValueError("reproduce grid_posterior: --steps/--particles/--seed are the store's")
        trials = f" --trials {args.trials}" if args.trials is not None else ""
        command = f"infoseek reproduce grid_posterior{trials} --workers {workers} --out {out}"
        path = grid_posterior.reproduce_grid_posterior(
            out, trials=args.trials, workers=workers, command=command
        )
        print(f"wrote {path}")
        return 0
    if args.figure == "ablation":
        return _ablation(out, args)
    if args.figure == "horizon":
        return _horizon(out, args)
    if args.figure == "learned":
        return _learned(out, args)
    if args.figure == "beacon":
        plan = beacon_plan(args.trials or 500, args.steps, args.particles, args.seed)
    elif args.figure == "beacon_v1":
        v1_trials = args.trials or DEFAULT_V1_TRIALS
        plan = beacon_v1_plan(v1_trials, args.steps, args.particles, args.seed)
    else:
        plan = fig1_plan(args.trials or 1000, args.steps, args.particles, args.seed)
    store = out / "store"
    code, _ = run_plan(plan, store, args)
    if code != 0:
        return code
    for path in plot_fig1_from_store(store, out / args.figure):
        print(f"wrote {path}")
    if args.figure == "beacon_v1":  # why Claim A comes out as it does there
        for path in beacon_mechanism.reproduce_beacon_mechanism(
            out,
            decision_trials=min(plan.trials, beacon_mechanism.DEFAULT_DECISION_TRIALS),
            switched_trials=min(plan.trials, beacon_mechanism.DEFAULT_SWITCHED_TRIALS),
            workers=workers,
            steps=args.steps,
            particles=args.particles,
        ):
            print(f"wrote {path}")
    return 0


def _beacon_grid(out: Path, args: argparse.Namespace, workers: int) -> int:
    """``infoseek reproduce beacon_grid``: a beacon store's episodes beside an exact 3-D grid
    posterior, into ``OUT/beacon_grid.json``."""
    if args.steps is not None or args.particles is not None or args.seed != 0:
        raise ValueError("reproduce beacon_grid: --steps/--particles/--seed are the store's")
    store = args.store if args.store is not None else beacon_grid.BEACON_STORE
    texts = list(args.group or [])
    groups = [beacon_grid.parse_group(text) for text in texts] or list(beacon_grid.DEFAULT_GROUPS)
    command = "infoseek reproduce beacon_grid"
    if args.trials is not None:
        command += f" --trials {args.trials}"
    if args.store is not None:
        command += f" --store {Path(args.store).as_posix()}"
    command += "".join(f" --group {text}" for text in texts)
    if args.halved_cells:
        command += " --halved-cells"
    command += f" --workers {workers} --out {out}"
    path = beacon_grid.reproduce_beacon_grid(
        out,
        trials=args.trials,
        workers=workers,
        store=store,
        groups=groups,
        halved=args.halved_cells,
        command=command,
    )
    print(f"wrote {path}")
    return 0


def _horizon(out: Path, args: argparse.Namespace) -> int:
    """``infoseek reproduce horizon``: the Fig. 1 groups (resumed) and the study's groups into
    ``OUT/store``, then Fig. 1 (its panel (c) is the receding-horizon gain)."""
    plans = [
        fig1_plan(args.trials or 1000, args.steps, args.particles, args.seed),
        *horizon_plans(args.trials, args.steps, args.particles, args.seed),
    ]
    store = out / "store"
    for plan in plans:
        plan.validate(store)  # every group before any trial is stored
    for plan in plans:
        code, _ = run_plan(plan, store, args)
        if code != 0:
            return code
    for path in plot_fig1_from_store(store, out / "fig1"):
        print(f"wrote {path}")
    return 0


def _learned(out: Path, args: argparse.Namespace) -> int:
    """``infoseek reproduce learned``: every setting's missing training seeds (``infoseek
    train --algo dagger``) and the PPO fine-tuning, then the benchmark stores (resumed) and the
    learning curves."""
    if any(getattr(args, name) is not None for name in ("trials", "steps", "particles")):
        raise ValueError("reproduce learned: --trials/--steps/--particles are the study's")
    if args.seed != 0:
        raise ValueError("reproduce learned: --seed is the study's (0)")
    from infoseek.experiments.train import add_train_arguments, run_train

    _, workers = execution(args)
    parser = argparse.ArgumentParser(prog="infoseek train")
    add_train_arguments(parser)
    for setting in learned.SETTINGS:
        for seed, run in zip(
            learned.TRAINING_SEEDS, learned.run_directories(out, setting.name), strict=True
        ):
            if (run / "model.zip").is_file():
                continue
            arguments = setting.train_command(seed, run)[1:]
            code = run_train(parser.parse_args([*arguments, "--num-cpus", str(workers)]))
            if code != 0:
                return code
    if not (out / learned.FINE_TUNED / "model.zip").is_file():
        code = run_train(parser.parse_args(learned.fine_tune_command(out)[1:]))
        if code != 0:
            return code
    for bench in learned.BENCHES:
        code, _ = run_plan(bench.plan(out), out / bench.name, args)
        if code != 0:
            return code
    for path in learned.plot_learning_curves(out, out / "learning_curves"):
        print(f"wrote {path}")
    return 0


def _fig2(out: Path, args: argparse.Namespace) -> int:
    """``infoseek reproduce fig2``: the episode, its figure and the snapshot masses."""
    if args.backend is not None or args.workers is not None or args.address:
        print("reproduce fig2: one episode; --backend/--workers/--address are ignored")
    started = time.perf_counter()
    result = fig2.reproduce_fig2(out, steps=args.steps, particles=args.particles, seed=args.seed)
    elapsed = time.perf_counter() - started
    x, y, psi = result.truth
    print(f"fig2: episode seed {result.env_seed}; beacon at ({x:.2f}, {y:.2f}), psi {psi:.4f}")
    for step, mass in sorted(result.snapshot_masses.items()):
        print(f"  t = {step:>2}: posterior mass within 1 unit (agent 0) {mass:.3f}")
    for path in result.paths:
        print(f"wrote {path}")
    record = write_fig2_record(
        out, result, seed=args.seed, steps=args.steps, particles=args.particles, wall_time=elapsed
    )
    print(f"wrote {record}")
    return 0


def _ablation(out: Path, args: argparse.Namespace) -> int:
    """``infoseek reproduce ablation``: every setting's store, then the table and figure, then
    the decisions study (kept in ``OUT/decisions.json``)."""
    if args.steps is not None or args.particles is not None:
        raise ValueError("reproduce ablation: --steps/--particles are fixed by its settings")
    trials = args.trials if args.trials is not None else ablation.DEFAULT_TRIALS
    plans = list(ablation.ablation_plans(trials=trials, seed=args.seed))
    for _, plan in plans:
        plan.validate()  # every setting before any store is written
    for name, plan in plans:
        code, _ = run_plan(plan, out / name / "store", args)
        if code != 0:
            return code
    rows = ablation.ablation_rows(out)
    print(ablation.format_table(rows))
    for path in ablation.write_results(out, rows):
        print(f"wrote {path}")
    decision_rows = decisions.read_decisions(out)
    if decision_rows is None:
        print("decisions: single-node's choices along pairwise-node episodes", flush=True)
        decision_rows = decisions.decision_rows(seed=args.seed)
        for path in decisions.write_decisions(out, decision_rows):
            print(f"wrote {path}")
    print(decisions.format_decisions(decision_rows))
    return 0
