"""``infoseek page STUDY``: rewrite a results page from the study's results already on disk (no
trial is run), e.g. after a change of the page's text or of the analysis."""

from __future__ import annotations

import argparse
from pathlib import Path

from infoseek.experiments.arguments import check_writable_file
from infoseek.experiments.pages.registry import PAGES, write_page

__all__ = ["add_page_arguments", "run_page_command"]


def add_page_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``infoseek page``."""
    parser.add_argument("study", choices=sorted(PAGES), help="which results page")
    parser.add_argument(
        "--results",
        type=Path,
        default=None,
        help="the study's results directory (default experiments/results/<its directory>)",
    )
    parser.add_argument(
        "--out", type=Path, default=None, help="the page to write (default docs/results/STUDY.md)"
    )


def run_page_command(args: argparse.Namespace) -> int:
    """``infoseek page STUDY``; returns the exit code."""
    page = PAGES[args.study]
    results = args.results if args.results is not None else page.default_results
    out = args.out if args.out is not None else page.default_page
    if not results.is_dir():
        raise ValueError(f"--results {results}: no such directory")
    check_writable_file(out, "--out")
    print(f"wrote {write_page(args.study, results, out)}")
    return 0
