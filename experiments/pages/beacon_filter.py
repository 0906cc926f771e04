"""The beacon filter-settings page (``docs/results/beacon_filter.md``): which settings of
``beacon_v0``'s particle filter let the team localise the beacon sooner, and are the fixes
right?

One store per setting (a directory of the study's directory; ``reference/`` holds
``beacon_v0``'s defaults), each written by ``infoseek bench`` with the same seed, planner and
fleet size and different ``--env-kwarg`` filter options, so every store faces the same beacons
trial by trial (:mod:`~infoseek.experiments.pages.paired_stores`).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from infoseek.experiments.environments import changed_settings, env_defaults
from infoseek.experiments.pages.markdown import code_block, display_path, page_text, table
from infoseek.experiments.pages.paired_stores import LabelledStore, paired_table
from infoseek.experiments.pages.provenance import StoreProvenance, stores_section
from infoseek.experiments.store import read_manifest

__all__ = ["PAIRWISE_DIRECTORY", "REFERENCE_STORE", "beacon_filter_page"]

#: The directory of the store every other one is compared with (``beacon_v0``'s defaults).
REFERENCE_STORE = "reference"
#: The subdirectory of the pairwise-node checks (one store per setting), paired with the beacon
#: study's store (``beacon/store`` beside the study's directory), which holds ``beacon_v0``'s
#: defaults with the same seeds.
PAIRWISE_DIRECTORY = "pairwise"

_INTRO = (
    "A question of the beacon issue: which settings of `beacon_v0`'s particle filter let the "
    "team localise the beacon sooner? Each store below runs the single-node planner with four "
    "quadrotors on `beacon_v0` over the same seeded episodes (trial `k` of every store faces "
    "the same beacon), with the environment's defaults except the filter options in its first "
    "column: the progressive correction (`tempering_ess`, whose Metropolis moves target the "
    "exact posterior given every kept observation), the filters' noise floor "
    "(`filter_max_snr`; the planners score with the same floored likelihood), the roughening "
    "constant, the resampling threshold and the particle count. The single-node planner "
    "localises as fast as the pairwise-node planner on this environment (20.72 against 20.81 "
    "steps over the 500 trials of the [beacon](beacon.md) study) at a third of its planning "
    "time. Time to localise as on the beacon page: agent 0's mass within the localisation "
    "radius of its own estimate reaches 0.9, censored at the episode length; it is read from "
    "the filter, so the column *end more than the radius off the truth* says how often a "
    "setting's estimate was wrong at the last step."
)


def _label(store: Path) -> str:
    """The filter options a store's run changed (``beacon_v0``'s defaults: the reference)."""
    options = read_manifest(store)["config"].get("env_kwargs", {})
    if not options:
        return "defaults (reference)"
    return ", ".join(f"`{key}={json.dumps(value)}`" for key, value in sorted(options.items()))


def _natural_key(name: str) -> list[tuple[int, str]]:
    """``name`` ordered with its digit runs as numbers (``particles_4000`` before
    ``particles_16000``)."""
    return [(int(part), "") if part.isdigit() else (-1, part) for part in re.split(r"(\d+)", name)]


def _stores(results: Path) -> list[LabelledStore]:
    """The reference store first, then every other store under ``results`` by name (numbers
    in names by value)."""
    found = sorted(child for child in results.iterdir() if (child / "manifest.json").is_file())
    if not any(child.name == REFERENCE_STORE for child in found):
        raise ValueError(f"{results}: no {REFERENCE_STORE}/ results store")
    found.sort(key=lambda child: (child.name != REFERENCE_STORE, _natural_key(child.name)))
    return [LabelledStore(_label(child), child) for child in found]


_PAIRWISE_INTRO = (
    "A setting is checked with the pairwise-node planner on more episodes: each store below "
    "runs it with four quadrotors over the seeded episodes of the [beacon](beacon.md) study's "
    "store (`beacon_v0`'s defaults, the same seed), and is paired with that store's "
    "`pairwise/4` trials. `beacon_v1` is `beacon_v0` with the setting "
    "`resample_threshold=0.5, tempering_ess=0.5` (a test holds the two equal bit for bit), so "
    "its row is `beacon_v1` against `beacon_v0`."
)


def _pairwise_section(results: Path) -> tuple[list[str], list[str], list[StoreProvenance]]:
    """The pairwise-node checks' commands, page blocks and provenance (empty if none)."""
    directory = results / PAIRWISE_DIRECTORY
    reference = results.parent / "beacon" / "store"
    if not directory.is_dir():
        return [], [], []
    stores = [
        LabelledStore(_label(child), child)
        for child in sorted(directory.iterdir())
        if (child / "manifest.json").is_file()
    ]
    if not stores:
        return [], [], []
    comparison = paired_table(stores, reference, "filter options")
    blocks = [
        "## The pairwise-node planner on the beacon study's episodes",
        _PAIRWISE_INTRO,
        table(comparison.header, comparison.rows),
    ]
    return comparison.commands, blocks, comparison.provenances


_PARTICLES_INTRO = (
    "`beacon_v1`'s two filter settings with the particle count varied: the stores above that "
    "differ from `beacon_v0` by those settings and `n_particles` only, each paired with the "
    "one at `beacon_v0`'s {default} particles (the count `beacon_v1` uses), trial by trial. "
    "Where more particles no longer localise sooner, the particle count is not what limits "
    "the filter."
)


def _particles_section(stores: list[LabelledStore]) -> list[str]:
    """The particle-count blocks for ``beacon_v1``'s settings, from the page's ``stores``
    (empty with fewer than two such stores or none at the default count)."""
    settings = changed_settings("beacon_v1", "beacon_v0")
    default = int(env_defaults("beacon_v0")["n_particles"])
    chosen: dict[int, Path] = {}
    for store in stores:
        options = dict(read_manifest(store.path)["config"].get("env_kwargs", {}))
        particles = int(options.pop("n_particles", default))
        if options == settings:
            chosen[particles] = store.path
    if len(chosen) < 2 or default not in chosen:
        return []
    stores = [LabelledStore(str(n), chosen[n]) for n in sorted(chosen)]
    comparison = paired_table(stores, chosen[default], "particles")
    return [
        "## beacon_v1's filter against the particle count",
        _PARTICLES_INTRO.format(default=default),
        table(comparison.header, comparison.rows),
    ]


def beacon_filter_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the beacon filter-settings page.

    Args:
        results: The study's directory (one store per setting, ``reference/`` among them).
        page: Where the page is written.
    """
    results, page = Path(results), Path(page)
    stores = _stores(results)
    comparison = paired_table(stores, stores[0].path, "filter options")
    pairwise_commands, pairwise_blocks, pairwise_provenances = _pairwise_section(results)
    commands = comparison.commands + pairwise_commands
    commands.append(
        f"infoseek page beacon_filter --results {display_path(results)} --out {display_path(page)}"
    )
    return page_text(
        [
            "# Beacon: time to localise against the filter settings (`beacon_v0`)",
            _INTRO,
            "## Commands",
            code_block("\n".join(commands), "bash"),
            "## Results",
            table(comparison.header, comparison.rows),
            *_particles_section(stores),
            *pairwise_blocks,
            stores_section(comparison.provenances + pairwise_provenances),
        ]
    )
