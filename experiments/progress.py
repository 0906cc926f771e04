"""The progress bar of long commands (trials of ``bench``/``verify``, steps of ``demo``)."""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["progress_bar"]


def progress_bar(
    total: int, desc: str, progress: bool | None, initial: int = 0, unit: str = "trial"
) -> Any:
    """A tqdm bar (count, elapsed time and the estimated time left) on stderr.

    Args:
        total: Units in all.
        desc: Label of the bar.
        progress: Show it (``None``: only on a terminal).
        initial: Units already done.
        unit: What is counted.
    """
    from tqdm import tqdm

    return tqdm(
        total=total,
        initial=initial,
        unit=unit,
        desc=desc,
        disable=(not progress) if progress is not None else None,
        file=sys.stderr,
    )
