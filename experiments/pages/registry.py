"""The results pages: each page's name, the study directory it is written from and its writer.

``docs/results/<name>.md`` is written from ``experiments/results/<directory>`` (paths relative
to the repository's root, where ``infoseek page`` runs by default).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from infoseek.experiments.pages.ablation import ablation_page
from infoseek.experiments.pages.beacon import beacon_page, beacon_v1_page
from infoseek.experiments.pages.beacon_filter import beacon_filter_page
from infoseek.experiments.pages.beacon_grid import beacon_grid_page
from infoseek.experiments.pages.beacon_particles import beacon_particles_page
from infoseek.experiments.pages.fig1 import fig1_page
from infoseek.experiments.pages.fig2 import fig2_page
from infoseek.experiments.pages.grid_posterior import grid_posterior_page
from infoseek.experiments.pages.horizon import horizon_page
from infoseek.experiments.pages.learned import learned_page
from infoseek.experiments.pages.markdown import display_path
from infoseek.experiments.pages.rl import rl_page

__all__ = [
    "DOCS_RESULTS",
    "MIN_PAGE_TRIALS",
    "PAGES",
    "RESULTS",
    "Page",
    "render_page",
    "write_page",
]

#: Where the committed results lie, relative to the repository's root.
RESULTS = Path("experiments/results")
#: Trials per group a Monte Carlo study needs for its page (the paired tests need two).
MIN_PAGE_TRIALS = 2
#: Where the committed pages lie, relative to the repository's root.
DOCS_RESULTS = Path("docs/results")


@dataclass(frozen=True)
class Page:
    """One results page.

    Attributes:
        name: The page (``docs/results/<name>.md``) and the ``infoseek page`` argument.
        directory: Its study's directory under :data:`RESULTS`.
        render: ``render(results, page)``: the Markdown, from the study's directory, for a page
            written at ``page``.
    """

    name: str
    directory: str
    render: Callable[[str | os.PathLike[str], str | os.PathLike[str]], str]

    @property
    def default_results(self) -> Path:
        """The committed study directory."""
        return RESULTS / self.directory

    @property
    def default_page(self) -> Path:
        """The committed page."""
        return DOCS_RESULTS / f"{self.name}.md"


#: Every results page, by name.
PAGES: dict[str, Page] = {
    page.name: page
    for page in (
        Page("fig1", "fig1", fig1_page),
        Page("fig2", "fig2", fig2_page),
        Page("beacon", "beacon", beacon_page),
        Page("beacon_v1", "beacon_v1", beacon_v1_page),
        Page("beacon_particles", "beacon_particles", beacon_particles_page),
        Page("beacon_filter", "beacon_filter", beacon_filter_page),
        Page("ablation", "ablation", ablation_page),
        Page("horizon", "fig1", horizon_page),
        Page("rl", "rl", rl_page),
        Page("grid_posterior", "grid_posterior", grid_posterior_page),
        Page("beacon_grid", "beacon_grid", beacon_grid_page),
        Page("beacon_grid_v1", "beacon_grid_v1", beacon_grid_page),
        Page("learned", "learned", learned_page),
    )
}


def render_page(name: str, results: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """The Markdown of the page ``name`` from the study directory ``results``, for a page
    written at ``page``: a MyST comment naming the command that wrote it, then the page.

    Raises:
        ValueError: Unknown page, or ``results`` lacks what the page is written from.
    """
    if name not in PAGES:
        raise ValueError(f"unknown results page {name!r}; one of {sorted(PAGES)}")
    source = display_path(results)
    header = (
        f"% Generated from {source} by experiments/pages/ (`infoseek page {name} --results "
        f"{source}` rewrites it): edit the generator, not this file.\n"
    )
    return header + PAGES[name].render(results, page)


def write_page(name: str, results: str | os.PathLike[str], page: str | os.PathLike[str]) -> Path:
    """Render the page ``name`` from the study directory ``results`` and write it to ``page``
    (only once it is rendered, so a failure leaves the old page); returns ``page``.

    Raises:
        ValueError: Unknown page, or ``results`` lacks what the page is written from.
    """
    text = render_page(name, results, page)
    path = Path(page)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path
