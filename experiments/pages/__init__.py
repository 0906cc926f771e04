"""Results pages: the Markdown pages of ``docs/results/``, written from the studies' results.

Each page is a deterministic function of a study's results directory (its store's manifest and
records, the files a study wrote next to it): the same files give the same bytes, so a test
regenerates every committed page and compares. Every number on a page comes from those files;
the prose around them is fixed text of the page's module. ``infoseek reproduce STUDY --page
FILE`` writes the page after the study; ``infoseek page STUDY`` rewrites it from the results
already there (:mod:`~infoseek.experiments.pages.command`).

This package sits above the studies: it imports them, the analysis and the store, and nothing
below it imports it.
"""
