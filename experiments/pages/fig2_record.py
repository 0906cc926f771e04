"""``OUT/fig2.json``: the numbers and provenance of the Fig. 2 episode, kept next to its figure.

:func:`~infoseek.experiments.studies.fig2.reproduce_fig2` returns the episode's seed, true beacon
and snapshot masses; :func:`write_fig2_record` keeps them with the settings, the numerics, the
machine and the wall time of the run, and the Fig. 2 page is written from that file
(:func:`read_fig2_record`).
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from infoseek.experiments.studies.fig2 import Fig2Result

__all__ = ["FIG2_RECORD", "Fig2Record", "read_fig2_record", "write_fig2_record"]

#: The record's file name in the study's directory.
FIG2_RECORD = "fig2.json"


@dataclass(frozen=True)
class Fig2Record:
    """What one ``infoseek reproduce fig2`` run produced and where it ran.

    Attributes:
        seed: Root seed (``--seed``).
        steps: Episode length asked for (``None``: the study's default).
        particles: Particles per belief asked for (``None``: the environment's).
        env_seed: The episode's seed.
        truth: True beacon state ``(x, y, psi)``.
        snapshot_masses: Step -> agent 0's posterior mass within the localisation radius.
        wall_time: Seconds the episode and its figure took.
        numerics: :func:`infoseek.experiments.numerics.describe` of the run.
        machine: :func:`infoseek.experiments.machine.describe_machine` of the run.
    """

    seed: int
    steps: int | None
    particles: int | None
    env_seed: int
    truth: tuple[float, float, float]
    snapshot_masses: dict[int, float]
    wall_time: float
    numerics: dict[str, Any]
    machine: dict[str, Any]


def write_fig2_record(
    out: str | os.PathLike[str],
    result: Fig2Result,
    *,
    seed: int,
    steps: int | None,
    particles: int | None,
    wall_time: float,
) -> Path:
    """Write ``out/fig2.json`` for one run; returns its path.

    Args:
        out: The study's directory.
        result: What :func:`~infoseek.experiments.studies.fig2.reproduce_fig2` returned.
        seed: Its root seed.
        steps: Its episode length argument.
        particles: Its particles argument.
        wall_time: Seconds it took.
    """
    from infoseek.experiments.machine import describe_machine
    from infoseek.experiments.numerics import describe

    x, y, psi = (float(v) for v in result.truth)
    record = Fig2Record(
        seed=seed,
        steps=steps,
        particles=particles,
        env_seed=int(result.env_seed),
        truth=(x, y, psi),
        snapshot_masses={int(k): float(v) for k, v in sorted(result.snapshot_masses.items())},
        wall_time=round(float(wall_time), 3),
        numerics=describe(),
        machine=describe_machine(),
    )
    path = Path(out) / FIG2_RECORD
    path.write_text(json.dumps(asdict(record), indent=1, sort_keys=True) + "\n")
    return path


def read_fig2_record(out: str | os.PathLike[str]) -> Fig2Record:
    """The record in ``out/fig2.json``.

    Raises:
        ValueError: No record there, or one without a field.
    """
    path = Path(out) / FIG2_RECORD
    if not path.exists():
        raise ValueError(f"{path}: no Fig. 2 record (run `infoseek reproduce fig2 --out {out}`)")
    data = json.loads(path.read_text())
    try:
        return Fig2Record(
            seed=int(data["seed"]),
            steps=data["steps"],
            particles=data["particles"],
            env_seed=int(data["env_seed"]),
            truth=(float(data["truth"][0]), float(data["truth"][1]), float(data["truth"][2])),
            snapshot_masses={int(k): float(v) for k, v in data["snapshot_masses"].items()},
            wall_time=float(data["wall_time"]),
            numerics=dict(data["numerics"]),
            machine=dict(data["machine"]),
        )
    except KeyError as missing:
        raise ValueError(f"{path}: no field {missing}") from None
