"""The ``infoseek`` console entry point: pins the numerical environment, then runs the CLI.

Commands that run trials (``bench``, ``reproduce``, ``verify``) need the pinned numerical
environment of :mod:`infoseek.experiments.numerics` before NumPy is loaded, and every command
runs with one BLAS/OpenMP thread by default (:mod:`infoseek.experiments.threads`, opt out with
``INFOSEEK_THREADS``); this module sets both and only then imports
:mod:`infoseek.experiments.cli`. It also keeps freed NumPy temporaries in the C heap, in this
process and in the worker processes it starts (:mod:`infoseek.envs.heap`, opt out with
``INFOSEEK_HEAP_TUNING=0``): a setting of the program, which importing the library never makes.
"""

from __future__ import annotations

import os
import sys

from infoseek.experiments.numerics import pin
from infoseek.experiments.threads import limit_threads_early

#: Commands whose trials must reproduce on any machine.
TRIAL_COMMANDS = frozenset({"bench", "reproduce", "verify"})


def main() -> int:
    """Pin (for trial commands), one thread (every command), stop on SIGINT/SIGTERM as on
    Ctrl-C, then ``infoseek.experiments.cli.main``."""
    if len(sys.argv) > 1 and sys.argv[1] in TRIAL_COMMANDS:
        pin()
    limit_threads_early()
    _tune_heap()
    from infoseek.experiments.cli import main as cli_main
    from infoseek.experiments.cli import stop_on_signals

    stop_on_signals()
    return cli_main()


def _tune_heap() -> None:
    """The heap tuning of :mod:`infoseek.envs.heap`, here and (through the environment
    variable) in every worker process, unless ``INFOSEEK_HEAP_TUNING=0``."""
    from infoseek.envs import heap

    if os.environ.setdefault(heap.ENVIRONMENT_VARIABLE, "1") == "1":
        heap.tune_from_environment()


if __name__ == "__main__":
    raise SystemExit(main())
