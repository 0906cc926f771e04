"""``python -m infoseek.experiments ...``: the ``infoseek`` command."""

from infoseek.experiments.launch import main

raise SystemExit(main())
