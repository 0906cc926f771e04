"""Markdown building blocks of the results pages (paths, code blocks, tables, figures)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

__all__ = ["code_block", "display_path", "figure", "page_text", "table"]


def display_path(path: str | os.PathLike[str]) -> str:
    """``path`` as a page shows it: relative to the working directory, POSIX separators (the
    same bytes wherever the checkout lies, when run from its root)."""
    return Path(os.path.relpath(Path(path))).as_posix()


def code_block(text: str, language: str = "text") -> str:
    """A fenced code block of ``text`` (one trailing newline inside)."""
    return f"```{language}\n{text.rstrip()}\n```"


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A Markdown pipe table.

    Args:
        header: Column titles.
        rows: Cells, one sequence per row, as many as ``header``.

    Raises:
        ValueError: A row with another number of cells.
    """
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"table row {list(row)} has {len(row)} cells, not {len(header)}")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines.extend("| " + " | ".join(row) + " |" for row in rows)
    return "\n".join(lines)


def figure(alt: str, image: str | os.PathLike[str], page: str | os.PathLike[str]) -> str:
    """An image link to ``image`` from the page file ``page`` (a relative link)."""
    target = os.path.relpath(Path(image), Path(page).parent)
    return f"![{alt}]({Path(target).as_posix()})"


def page_text(sections: Sequence[str]) -> str:
    """A page of ``sections`` (blocks of Markdown), separated by blank lines, with one final
    newline; empty sections are left out."""
    return "\n\n".join(section for section in sections if section) + "\n"
