"""The studies: each one a question asked of stored trials, with its plan, tables and figures.

* :mod:`.fig1`: the paper's Fig. 1 (bearings-only search, Monte Carlo);
* :mod:`.fig2`: the paper's Fig. 2 (one rescue-beacon episode);
* :mod:`.beacon`: the beacon Monte Carlo study (not in the paper);
* :mod:`.ablation`: what the pairwise-node gain over single-node (Claim A) depends on;
* :mod:`.decisions`: how often pairwise-node decides differently from single-node;
* :mod:`.claims`: the paired tests of a store's claims (``infoseek claims``).

A study imports the harness (plans, stores, records: :mod:`infoseek.experiments.bench`, ...)
and the analysis (:mod:`infoseek.experiments.analysis`, :mod:`infoseek.experiments.bound`,
:mod:`infoseek.experiments.plot`), never another study; the harness and the analysis import no
study (``tests/test_packaging.py`` checks both). What combines studies (the command line,
the results pages) sits above them.
"""
