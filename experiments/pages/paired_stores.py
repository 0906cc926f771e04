"""A table of bench stores run over the same seeded episodes, each paired with a reference.

Stores written by ``infoseek bench`` with the same seed, planner and fleet size face the same
targets trial by trial (the harness derives every trial's seeds from the run's seed), so a
setting that differs only in the environment's options (particles, filter settings) is compared
with the reference on the same episodes. One row per store: the time to localise (agent 0's
mass within the localisation radius reaches 0.9, censored at the episode length), how many
trials never localised, how many *end* with agent 0's MMSE more than the localisation radius
from the truth (the time to localise is read from the filter itself, so a filter that
concentrates on a wrong place counts as localised: this column says how often the estimate was
wrong), the mean final mass, and the paired difference from the reference with its standard
error and a two-sided Wilcoxon p-value.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from infoseek.experiments.analysis import summarise, times_to_localise
from infoseek.experiments.columns import TrialView, read_trials
from infoseek.experiments.pages.bench_commands import bench_commands
from infoseek.experiments.pages.provenance import StoreProvenance, read_provenance
from infoseek.experiments.studies.claims import baseline_lines

__all__ = ["LabelledStore", "PairedTable", "ended_off_target", "paired_table"]


@dataclass(frozen=True)
class LabelledStore:
    """A store and the label of its row.

    Attributes:
        label: The row's first cell.
        path: The store's directory.
    """

    label: str
    path: Path


@dataclass(frozen=True)
class PairedTable:
    """The rows of a paired comparison, the commands that wrote its stores and their
    provenance.

    Attributes:
        header: Column titles (the first is the caller's label title).
        rows: One row per store and group.
        commands: One ``infoseek bench`` command per store and group.
        provenances: Each store's manifest and trial times, in the rows' order.
    """

    header: list[str]
    rows: list[list[str]]
    commands: list[str]
    provenances: list[StoreProvenance]


def ended_off_target(trials: Sequence[TrialView]) -> int | None:
    """How many ``trials`` end with agent 0's MMSE farther than the localisation radius from
    the truth (``None`` if the store did not record the error)."""
    count = 0
    for trial in trials:
        if trial.error_agent0 is None or trial.radius is None:
            return None
        count += int(float(trial.error_agent0[-1]) > trial.radius)
    return count


def paired_table(
    stores: Sequence[LabelledStore], reference: Path | None, label_title: str
) -> PairedTable:
    """The comparison table of ``stores`` (module docstring), each paired with the store at
    ``reference`` (one of them or another; ``None``: no paired column entries).

    Args:
        stores: The stores, in row order (a store of several groups gives a row per group,
            labelled with the group).
        reference: The directory of the store every other one is paired with.
        label_title: The title of the label column.
    """
    baseline = read_trials(reference) if reference is not None else []
    rows, commands, provenances = [], [], []
    for store in stores:
        provenance = read_provenance(store.path)
        provenances.append(provenance)
        config = provenance.manifest["config"]
        commands.extend(bench_commands(store.path, config, provenance.groups))
        steps = int(config["steps"])
        trials = read_trials(store.path)
        summaries = summarise(trials, steps)
        for group in summaries:
            q25, median, q75 = group.ttl_quartiles
            key = (group.planner, group.n_agents)
            members = [t for t in trials if (t.planner, t.n_agents) == key]
            off = ended_off_target(members)
            paired, sooner = "(the reference)", ""
            if baseline and store.path != reference:
                lines = baseline_lines(members, baseline, steps)
                paired = lines[0].split(": ", 1)[1] if lines else "no trials in common"
                sooner = _percent_sooner(members, baseline, key, steps)
            rows.append(
                [
                    store.label
                    if len(summaries) == 1
                    else f"{store.label}: {group.planner}, n_v = {group.n_agents}",
                    str(group.trials),
                    f"{group.ttl_mean:.2f} ({q25:.0f} / {median:.0f} / {q75:.0f})",
                    f"{group.never} of {group.trials}",
                    "not recorded" if off is None else f"{off} of {group.trials}",
                    f"{group.final_mass:.3f}",
                    paired,
                    sooner,
                ]
            )
    header = [
        label_title,
        "trials",
        "time to localise: mean (q25 / median / q75)",
        "never localised",
        "end more than the radius off the truth",
        "final mass (mean)",
        "paired with the reference (mean ttl, difference, two-sided Wilcoxon)",
        "sooner than the reference (% of its mean ttl over the paired trials)",
    ]
    return PairedTable(header, rows, commands, provenances)


def _percent_sooner(
    trials: Sequence[TrialView], baseline: Sequence[TrialView], key: tuple[str, int], steps: int
) -> str:
    """How much sooner ``trials`` localise than ``baseline`` over the trials both hold, in
    percent of the baseline's mean (negative: later); empty without common trials."""
    mine = times_to_localise(trials, key[0], key[1], steps)
    theirs = times_to_localise(baseline, key[0], key[1], steps)
    common = sorted(set(mine) & set(theirs))
    if not common:
        return ""
    reference = sum(theirs[k] for k in common) / len(common)
    here = sum(mine[k] for k in common) / len(common)
    return f"{100.0 * (reference - here) / reference:+.1f} %"
