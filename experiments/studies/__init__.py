"""The studies: each one a question asked of stored trials, with its plan, tables and figures.

* :mod:`.fig1`: the paper's Fig. 1 (bearings-only search, Monte Carlo);
* :mod:`.fig2`: the paper's Fig. 2 (one rescue-beacon episode);
* :mod:`.beacon`: the beacon Monte Carlo study (not in the paper);
* :mod:`.ablation`: what the pairwise-node gain over single-node (Claim A) depends on;
* :mod:`.decisions`: how often pairwise-node decides differently from single-node;
* :mod:`.claims`: the paired tests of a store's claims (``infoseek claims``);
* :mod:`.horizon`: the receding-horizon planner and the clairvoyant reference on the Fig. 1
  store's targets (not in the paper);
* :mod:`.grid_posterior`: the Fig. 1 store's episodes rerun beside an exact grid posterior (the
  particle filter's own bias);
* :mod:`.beacon_grid`: a beacon store's episodes rerun beside an exact 3-D grid posterior (the
  beacon filter's own bias).

Layers of :mod:`infoseek.experiments`, from the bottom:

* **harness**: plans, trials, seeds, executors, stores and their records
  (:mod:`~infoseek.experiments.bench`, :mod:`~infoseek.experiments.trial`,
  :mod:`~infoseek.experiments.record`, :mod:`~infoseek.experiments.store`, ...), and the
  planner factories whose import paths are stored planner labels, so they stay where the
  stores name them: :mod:`infoseek.experiments.decisions` (the switched planners) and
  :mod:`infoseek.experiments.clairvoyant` (the clairvoyant reference);
* **analysis**: pure functions and figures over stored trials that more than one study or
  command uses: :mod:`infoseek.experiments.analysis`, :mod:`infoseek.experiments.columns`,
  :mod:`infoseek.experiments.bound` (the clairvoyant Gaussian/Fisher estimate, used by
  ``claims`` and the Fig. 1 figure) and :mod:`infoseek.experiments.plot` (the Fig. 1 figure,
  drawn by ``infoseek plot`` for any store as well as by ``reproduce fig1``/``beacon``);
* **studies**: this subpackage. A study imports the harness and the analysis, never another
  study;
* **top**: what combines studies: the command line (:mod:`~infoseek.experiments.cli`,
  :mod:`~infoseek.experiments.reproduce`, :mod:`~infoseek.experiments.launch`) and the
  results pages (:mod:`infoseek.experiments.pages`).

The harness and the analysis import no study. ``tests/test_packaging.py`` checks both rules
from the modules' import statements.
"""
