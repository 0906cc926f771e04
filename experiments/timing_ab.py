"""``infoseek timing --baseline DIR``: the same benchmarks, this version against another one.

A machine's speed drifts from minute to minute (other jobs, frequency scaling, a shared VM), so a
speed-up measured by two runs made at different times is not a measurement. Here the selected
benchmarks run in fresh processes, alternately under the installed infoseek (A) and under the
checkout at ``DIR`` (B, for example ``git worktree add ../base 310eb30``), ``--rounds`` times:
A B A B ... Each round gives both medians (or, with ``--statistic mean``, both means: what a
benchmark with rare expensive calls, such as ``beacon_v1``'s steps with moves, costs on
average) and their ratio B / A (how many times faster A is), and the table reports every round
and the median of the ratios.

The checkout is imported through a temporary folder ``infoseek/`` of links to its ``envs/``,
``planners/``, ``baselines/`` and ``experiments/`` put first on ``PYTHONPATH`` (the layout the
package installs as), so it needs no installation; it must be a version whose ``infoseek timing``
knows the selected benchmarks (those it does not know run only under this version).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["checkout_tree", "run_alternating"]

#: The package folders of a checkout (``infoseek.<name>`` once installed).
PACKAGES = ("envs", "planners", "baselines", "experiments")


def checkout_tree(checkout: Path, into: Path) -> Path:
    """A folder under ``into`` holding ``infoseek/<package>`` links to ``checkout``'s folders.

    Raises:
        ValueError: ``checkout`` lacks one of the package folders.
    """
    checkout = checkout.resolve()
    missing = [name for name in PACKAGES if not (checkout / name / "__init__.py").is_file()]
    if missing:
        raise ValueError(
            f"--baseline {checkout} is not an infoseek checkout (no {', '.join(missing)} package)"
        )
    package = into / "infoseek"
    package.mkdir(parents=True)
    for name in PACKAGES:
        (package / name).symlink_to(checkout / name, target_is_directory=True)
    return into


def _environment(python_path: Path | None) -> dict[str, str]:
    """This process's environment, with ``python_path`` first on ``PYTHONPATH`` if given."""
    environ = dict(os.environ)
    if python_path is not None:
        environ["PYTHONPATH"] = os.pathsep.join(
            [str(python_path), *filter(None, [environ.get("PYTHONPATH")])]
        )
    return environ


def baseline_timing(python_path: Path) -> tuple[list[str], bool]:
    """The benchmark names of the version imported through ``python_path``, and whether its
    ``infoseek timing`` reports the mean of the calls (versions before the mean column report
    medians only)."""
    script = (
        "import inspect, json; from infoseek.experiments import timing; "
        "print(json.dumps([list(timing.BENCHMARKS), '\"mean_ms\"' in inspect.getsource(timing)]))"
    )
    command = [sys.executable, "-c", script]
    environ = _environment(python_path)
    done = subprocess.run(command, env=environ, capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise ValueError(f"--baseline: cannot read its benchmarks: {last}")
    names, reports_mean = json.loads(done.stdout)
    return list(names), bool(reports_mean)


def _statistics(
    selected: list[str], repeats: int, python_path: Path | None, statistic: str
) -> dict[str, float]:
    """``statistic`` (``median`` or ``mean``) ms of each selected benchmark's calls, from one
    fresh ``infoseek timing`` process."""
    environ = _environment(python_path)
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "timing.json"
        command = [sys.executable, "-m", "infoseek.experiments", "timing"]
        command += ["--repeats", str(repeats), "--json", str(out)]
        for name in selected:
            command += ["--only", name]
        done = subprocess.run(command, env=environ, capture_output=True, text=True)
        if done.returncode != 0:
            which = "the baseline" if python_path is not None else "this version"
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            raise ValueError(f"infoseek timing of {which} failed: {last}")
        rows = json.loads(out.read_text())["results"]
    return {name: float(rows[name][f"{statistic}_ms"]) for name in selected}


def run_alternating(
    baseline: Path,
    selected: list[str],
    repeats: int,
    rounds: int,
    json_path: Path | None,
    statistic: str = "median",
) -> int:
    """Alternate this version (A) and the checkout ``baseline`` (B) ``rounds`` times; print
    each round's ``statistic`` of the calls and ratio B / A and the median ratio; returns the
    exit code.

    Args:
        baseline: The other version's checkout.
        selected: Benchmark names (both versions must know them).
        repeats: Timed calls per benchmark and process.
        rounds: Alternations (at least 1).
        json_path: Where to write the results as JSON, or ``None``.
        statistic: ``"median"`` or ``"mean"`` of each process's calls.
    """
    if isinstance(rounds, bool) or rounds < 1:
        raise ValueError(f"--rounds must be a positive integer, got {rounds}")
    if statistic not in ("median", "mean"):
        raise ValueError(f"--statistic must be 'median' or 'mean', got {statistic!r}")
    with tempfile.TemporaryDirectory() as scratch:
        tree = checkout_tree(baseline, Path(scratch))
        names, reports_mean = baseline_timing(tree)
        if statistic == "mean" and not reports_mean:
            raise ValueError(
                f"--statistic mean: the infoseek timing of --baseline {baseline} reports "
                "medians only (a version before the mean column); use --statistic median"
            )
        known = set(names)
        shared = [name for name in selected if name in known]
        rows: dict[str, list[dict[str, float]]] = {name: [] for name in selected}
        for _ in range(rounds):
            ours = _statistics(selected, repeats, None, statistic)
            theirs = _statistics(shared, repeats, tree, statistic) if shared else {}
            for name in selected:
                b_ms = theirs.get(name, math.nan)
                rows[name].append({"a_ms": ours[name], "b_ms": b_ms, "ratio": b_ms / ours[name]})
    print(
        f"A: this version; B: {baseline}; {rounds} rounds A B A B ..., {repeats} calls each, "
        f"their {statistic} compared"
    )
    print(f"{'benchmark':<34} {'round':>5} {'A ms':>9} {'B ms':>9} {'B / A':>7}")
    summary: dict[str, Any] = {}
    for name, per_round in rows.items():
        for r, row in enumerate(per_round):
            a_ms, b_ms, ratio = row["a_ms"], row["b_ms"], row["ratio"]
            print(f"{name:<34} {r + 1:>5} {a_ms:>9.2f} {b_ms:>9.2f} {ratio:>7.2f}")
        ratios = [row["ratio"] for row in per_round]
        if name not in known:
            summary[name] = {"rounds": [{"a_ms": row["a_ms"]} for row in per_round]}
            print(f"{name:<34} {'all':>5}  (the baseline has no such benchmark)")
            continue
        print(
            f"{name:<34} {'all':>5} {'':>9} {'':>9} {np.median(ratios):>7.2f}  "
            f"(B / A from {min(ratios):.2f} to {max(ratios):.2f})"
        )
        summary[name] = {"rounds": per_round, "median_ratio": float(np.median(ratios))}
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        report = {"baseline": str(baseline), "statistic": statistic, "results": summary}
        json_path.write_text(json.dumps(report, indent=2))
    return 0
