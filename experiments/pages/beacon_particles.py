"""The beacon particle-count page (``docs/results/beacon_particles.md``): does ``beacon_v0``'s
filter limit how soon the team localises the beacon?

One store per particle count (``n<N>/`` in the study's directory), each written by
``infoseek bench`` with the same seed, so trial ``k`` of every store faces the same beacon and
starts from the same draws (paired across stores); the pairwise-node planner with four
quadrotors, ``beacon_v0``'s defaults otherwise.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from infoseek.experiments.pages.markdown import code_block, display_path, page_text, table
from infoseek.experiments.pages.paired_stores import LabelledStore, paired_table
from infoseek.experiments.pages.provenance import stores_section

__all__ = ["REFERENCE_PARTICLES", "beacon_particles_page"]

#: The particle count the others are compared with (``beacon_v0``'s default).
REFERENCE_PARTICLES = 2000

_INTRO = (
    "A question of the beacon issue: is `beacon_v0`'s particle filter, not the planners, what "
    "limits how soon the beacon is localised? Each store below runs the pairwise-node planner "
    "with four quadrotors on `beacon_v0` with its defaults except the particles per belief "
    "(`--particles N`; the filters' noise floor `filter_max_snr = 5` stays), over the same "
    "seeded episodes: trial `k` of every store faces the same beacon, so every comparison is "
    "paired with the reference, 2000 particles (`beacon_v0`'s default). Time to localise as "
    "on the [beacon](beacon.md) page (agent 0's mass within the localisation radius reaches "
    "0.9; censored at the episode length)."
)


def _stores(results: Path) -> list[tuple[int, Path]]:
    """``(particles, store)`` of every results store ``n<N>`` under ``results``, by count."""
    found = []
    for child in results.iterdir():
        match = re.fullmatch(r"n(\d+)", child.name)
        if match and (child / "manifest.json").is_file():
            found.append((int(match.group(1)), child))
    if not found:
        raise ValueError(f"{results}: no n<N> results stores")
    return sorted(found)


def beacon_particles_page(results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the beacon particle-count page.

    Args:
        results: The study's directory (the store ``n<N>`` of each particle count).
        page: Where the page is written.
    """
    results, page = Path(results), Path(page)
    stores = [LabelledStore(str(particles), store) for particles, store in _stores(results)]
    reference = next((s.path for s in stores if s.label == str(REFERENCE_PARTICLES)), None)
    comparison = paired_table(stores, reference, "particles")
    commands = comparison.commands + [
        f"infoseek page beacon_particles --results {display_path(results)} --out "
        f"{display_path(page)}"
    ]
    return page_text(
        [
            "# Beacon: time to localise against the particle count (`beacon_v0`)",
            _INTRO,
            "## Commands",
            code_block("\n".join(commands), "bash"),
            "## Results",
            table(comparison.header, comparison.rows),
            stores_section(comparison.provenances),
        ]
    )
