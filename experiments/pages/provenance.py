"""Where a store's numbers come from: its manifest (configuration, numerics, machine, runs) and
the time its trials took (each record's own ``wall_time``), as a page section.

Stores written before the manifest recorded runs have no machine and no wall-clock time of the
commands that wrote them; the section says so rather than guess.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from infoseek.experiments.machine import format_machine
from infoseek.experiments.pages.markdown import display_path, table
from infoseek.experiments.policy_labels import display_name
from infoseek.experiments.store import read_columns, read_manifest

__all__ = [
    "GroupTime",
    "StoreProvenance",
    "format_numerics",
    "provenance_section",
    "read_provenance",
    "stores_section",
]


@dataclass(frozen=True)
class GroupTime:
    """The trials of one ``(planner, n_agents)`` group and the time they took.

    Attributes:
        planner: Planner label.
        n_agents: Fleet size.
        trials: Stored trials.
        seconds: Their ``wall_time`` summed (seconds of one worker).
    """

    planner: str
    n_agents: int
    trials: int
    seconds: float


@dataclass(frozen=True)
class StoreProvenance:
    """What a page reports of a store's origin.

    Attributes:
        store: The store's directory as the page shows it.
        manifest: Its manifest (``config``, ``created``, ``numerics``, ``parts``, ``runs``).
        groups: Its groups, sorted by planner and fleet size.
    """

    store: str
    manifest: Mapping[str, Any]
    groups: tuple[GroupTime, ...]

    @property
    def trials(self) -> int:
        """Stored trials."""
        return sum(group.trials for group in self.groups)


def read_provenance(store: str | os.PathLike[str]) -> StoreProvenance:
    """The manifest and per-group trial times of the store in ``store``."""
    tables, journal = read_columns(store, ("planner", "n_agents", "wall_time"))
    seen: set[str] = set()
    totals: dict[tuple[str, int], list[float]] = {}
    rows = [row for part in tables for row in part.to_pylist()] + journal
    for row in rows:
        if row["key"] in seen:
            continue
        seen.add(row["key"])
        entry = totals.setdefault((str(row["planner"]), int(row["n_agents"])), [0.0, 0.0])
        entry[0] += 1
        entry[1] += float(row["wall_time"])
    groups = tuple(
        GroupTime(planner=planner, n_agents=n, trials=int(count), seconds=seconds)
        for (planner, n), (count, seconds) in sorted(totals.items())
    )
    return StoreProvenance(store=display_path(store), manifest=read_manifest(store), groups=groups)


def format_numerics(numerics: Mapping[str, Any]) -> str:
    """One line of a manifest's ``numerics`` (NumPy, its SIMD, the BLAS loaded, numba)."""
    blas = ", ".join(
        f"{entry.get('library')} {entry.get('version')} ({entry.get('kernel')})"
        for entry in numerics.get("blas", [])
    )
    simd = "/".join(numerics.get("numpy_simd", [])) or "baseline"
    line = f"NumPy {numerics.get('numpy')} (SIMD {simd}); BLAS {blas or 'none loaded'}"
    if numerics.get("pinned"):
        line += "; one BLAS thread"
    numba = numerics.get("numba")
    if numba is not None:
        line += f"; numba {numba.get('numba')}, target {numba.get('cpu_name')}"
    return line


def _duration(seconds: float) -> str:
    """``seconds`` in the unit that reads best."""
    if seconds < 120:
        return f"{seconds:.1f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


def _runs_lines(runs: Sequence[Mapping[str, Any]]) -> list[str]:
    """One bullet per run the manifest records (or the sentence that none is)."""
    if not runs:
        return [
            "The manifest records no run: the store was written before the runs and their "
            "machine were recorded, so the machine and the wall-clock time of the commands "
            "that wrote it are not known; each trial's own time is recorded (the trial time here)."
        ]
    lines = ["Runs that stored trials, as the manifest records them:", ""]
    for run in runs:
        machine = run.get("machine")
        lines.append(
            f"* finished {run.get('finished', '?')}: {run.get('trials')} trials in "
            f"{_duration(float(run.get('wall_time', 0.0)))} of wall-clock time, backend "
            f"{run.get('backend')} with {run.get('workers')} worker(s), infoseek "
            f"{run.get('version')}; "
            + (format_machine(dict(machine)) if machine else "machine not recorded")
        )
    return lines


def provenance_section(provenance: StoreProvenance, heading: str = "Provenance") -> str:
    """The page section of one store: manifest, runs and the trials' time per group."""
    manifest = provenance.manifest
    config = manifest["config"]
    kwargs = config.get("env_kwargs") or {}
    settings = (
        f"`{config['env']}` with "
        + (f"`{json.dumps(kwargs, sort_keys=True)}`" if kwargs else "its defaults")
        + f", seed {config['seed']}, {config['steps']} steps per episode"
    )
    facts = [
        [
            "store",
            f"`{provenance.store}`: {provenance.trials} trials in "
            f"{len(manifest.get('parts', {}))} Parquet part(s)",
        ],
        ["configuration", settings],
        ["written by", f"infoseek {config.get('version', '?')}"],
        ["created", str(manifest.get("created", "?"))],
        ["numerics", format_numerics(manifest.get("numerics", {}))],
    ]
    times = [
        [
            f"`{display_name(group.planner)}`",
            str(group.n_agents),
            str(group.trials),
            _duration(group.seconds),
            f"{group.seconds / group.trials:.2f} s",
        ]
        for group in provenance.groups
    ]
    total = sum(group.seconds for group in provenance.groups)
    return "\n\n".join(
        [
            f"## {heading}",
            f"From `{Path(provenance.store, 'manifest.json').as_posix()}` and the trials' records:",
            table(["", "recorded"], facts),
            "\n".join(_runs_lines(manifest.get("runs", []))),
            f"Time of the trials (each record's `wall_time`, one worker each; "
            f"{_duration(total)} in all):",
            table(["planner", "agents", "trials", "trial time", "per trial"], times),
        ]
    )


def stores_section(provenances: Sequence[StoreProvenance], heading: str = "Provenance") -> str:
    """The page section of several stores of one study: one row per store (trials, creation,
    the time of its trials), the numerics each recorded, and whether any recorded its runs."""
    rows = [
        [
            f"`{p.store}`",
            str(p.trials),
            str(p.manifest.get("created", "?")),
            _duration(sum(group.seconds for group in p.groups)),
            format_numerics(p.manifest.get("numerics", {})),
        ]
        for p in provenances
    ]
    runs = [run for p in provenances for run in p.manifest.get("runs", [])]
    return "\n\n".join(
        [
            f"## {heading}",
            "From each store's `manifest.json` and its trials' records (trial time: each "
            "record's `wall_time`, summed, one worker each):",
            table(["store", "trials", "created", "trial time", "numerics"], rows),
            "\n".join(_runs_lines(runs)),
        ]
    )
