"""Sphinx extension of the infoseek documentation: the pages whose content lives in the code.

A page holds a marker line, an HTML comment (invisible where GitHub renders the page), that the
``source-read`` event replaces with text generated from the installed package before the page
is parsed. The manuals, the API reference and the command reference are therefore written once,
in the code, and cannot drift from it (PettingZoo's arrangement for its environment pages):

* ``<!-- infoseek:docstring MODULE -->``: the module's docstring, which is Markdown (the
  environment manuals ``infoseek.envs.bearings_v0`` and ``infoseek.envs.beacon_v0``). Sphinx
  roles written the reST way (``:mod:`x```) become MyST roles (``{mod}`x```).
* ``<!-- infoseek:api PACKAGE -->``: the package docstring, then one autodoc entry for every
  name in ``PACKAGE.__all__`` (a class with its public members, a function, a data value, a
  submodule as a link to its page or its own docstring).
* ``<!-- infoseek:apimodule MODULE -->``: one autodoc entry per name in ``MODULE.__all__``,
  without the module docstring (the environment pages, whose docstring is the page).
* ``<!-- infoseek:modules PACKAGE -->``: ``automodule`` of every module below ``PACKAGE`` (its
  docstring and its public names: ``__all__`` where the module defines it, else the public
  names it defines), found by walking the package, so new modules appear without an edit here.
* ``<!-- infoseek:cli -->``: the ``infoseek`` command's own ``--help`` and that of every
  subcommand, from the argument parser the command runs.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import os
import pkgutil
import re
import sys
import types
from typing import Any

from sphinx.application import Sphinx
from sphinx.pycode import ModuleAnalyzer

MARKER = re.compile(r"^<!-- infoseek:(\w[\w-]*) ?(\S*) -->$", re.MULTILINE)
#: A reST role in a Markdown docstring: ``:mod:`x``` or ``:py:class:`x```.
REST_ROLE = re.compile(r"(?<![\w`{]):((?:py:)?[a-z]+):`")
HEADING = re.compile(r"^(#{1,6}) ")
#: Modules that are never imported to document them (running them runs the command).
SKIPPED_MODULES = ("__main__",)
#: Environment modules whose docstring is a Markdown manual, with the page that renders it.
MANUAL_PAGES = {
    "infoseek.envs.bearings_v0": "/envs/bearings_v0",
    "infoseek.envs.beacon_v0": "/envs/beacon_v0",
}


def markdown_docstring(module_name: str) -> str:
    """A Markdown module docstring with its reST roles turned into MyST roles and its heading
    levels made consecutive (a manual that goes from ``#`` to ``###`` gets ``#`` and ``##``)."""
    text = inspect.cleandoc(importlib.import_module(module_name).__doc__ or "")
    if not text:
        raise ValueError(f"{module_name} has no docstring to render")
    return consecutive_headings(REST_ROLE.sub(r"{\1}`", text))


def consecutive_headings(text: str) -> str:
    """ATX headings outside fenced code renumbered to consecutive levels, in their order."""
    lines = text.splitlines()
    fenced = False
    headings: dict[int, int] = {}  # line index -> level
    for index, line in enumerate(lines):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced and (match := HEADING.match(line)):
            headings[index] = len(match.group(1))
    levels = {level: rank + 1 for rank, level in enumerate(sorted(set(headings.values())))}
    for index, level in headings.items():
        lines[index] = "#" * levels[level] + lines[index][level:]
    return "\n".join(lines)


def _rst_block(lines: list[str]) -> str:
    return "```{eval-rst}\n" + "\n".join(lines) + "\n```\n"


def _entry(package: str, name: str, value: Any) -> list[str]:
    """The autodoc directive of ``package.name``."""
    target = f"{package}.{name}"
    if isinstance(value, types.ModuleType):
        manual = MANUAL_PAGES.get(value.__name__)
        also = f" (the manual: :doc:`{manual}`)" if manual else ""
        return [f"* Module :py:mod:`{value.__name__}`{also}.", ""]
    if inspect.isclass(value):
        return [f".. autoclass:: {target}", "   :members:", "   :show-inheritance:", ""]
    if inspect.isroutine(value):
        return [f".. autofunction:: {target}", ""]
    return _data_entry(target, name, value)


def _attribute_doc(module_name: str, name: str) -> list[str] | None:
    """The ``#:`` comment or docstring of a module-level assignment, if it has one."""
    try:
        docs = ModuleAnalyzer.for_module(module_name).find_attr_docs()
    except Exception:  # a module without source (compiled, generated)
        return None
    return list(docs.get(("", name), [])) or None


def _data_entry(target: str, name: str, value: Any) -> list[str]:
    """``py:data`` with the documentation of the assignment that defines the value.

    A re-exported value (``registry`` is assigned in ``infoseek.envs.registration``) is
    documented by the ``#:`` comment where it is assigned, found among the loaded modules of
    the package holding the very same object (autodoc would look in the re-exporting module
    only, and then show the docstring of the value's type, e.g. ``dict``'s).
    """
    package = target.rsplit(".", 1)[0]
    root = package.split(".", 1)[0] + "."
    candidates = [package] + sorted(
        module_name
        for module_name, module in list(sys.modules.items())
        if module_name.startswith(root)
        and module_name != package
        and getattr(module, name, None) is value
    )
    for module_name in candidates:
        doc = _attribute_doc(module_name, name)
        if doc is not None:
            lines = [f".. py:data:: {target}"]
            if module_name != package:
                lines.append(f"   :canonical: {module_name}.{name}")
            return [*lines, "", *("   " + line if line else "" for line in doc), ""]
    raise ValueError(f"{target} is documented nowhere: give its assignment a #: comment")


def api_reference(package: str) -> str:
    """The package docstring and one entry per name of its ``__all__``."""
    module = importlib.import_module(package)
    names = getattr(module, "__all__", None)
    if not names:
        raise ValueError(f"{package} has no __all__ to document")
    lines = [f".. automodule:: {package}", "   :no-members:", ""]
    for name in names:
        lines += _entry(package, name, getattr(module, name))
    return _rst_block(lines)


def module_names(package: str) -> list[str]:
    """Every module below ``package`` (subpackages included), sorted, without ``__main__``."""
    root = importlib.import_module(package)
    found = [
        info.name
        for info in pkgutil.walk_packages(root.__path__, f"{package}.")
        if info.name.rsplit(".", 1)[-1] not in SKIPPED_MODULES
    ]
    return sorted(found)


def module_reference(name: str) -> str:
    """One module: its docstring and public names, re-exports listed where they are defined."""
    lines = [f".. automodule:: {name}", "   :members:"]
    reexported = _reexported(name)
    if reexported:
        lines.append("   :exclude-members: " + ", ".join(reexported))
    return _rst_block([*lines, ""])


def module_api(name: str) -> str:
    """The names of a module's ``__all__`` without its docstring (a manual's module: the
    docstring is the page itself)."""
    module = importlib.import_module(name)
    lines = [f".. py:module:: {name}", ""]
    for attribute in module.__all__:
        lines += _entry(name, attribute, getattr(module, attribute))
    return _rst_block(lines)


def _reexported(name: str) -> list[str]:
    """Classes and functions a module's ``__all__`` imports from another module below the
    package (documented where they are defined, so listed once)."""
    module = importlib.import_module(name)
    root = name.rsplit(".", 1)[0]
    return [
        attribute
        for attribute in getattr(module, "__all__", ())
        if getattr(getattr(module, attribute), "__module__", name) != name
        and getattr(getattr(module, attribute), "__module__", "").startswith(root)
    ]


def modules_reference(package: str) -> str:
    """A section per module below ``package`` with its docstring and public names."""
    parts = []
    for name in module_names(package):
        parts.append(f"## `{name}`\n\n" + module_reference(name))
    return "\n".join(parts)


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, Any]]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help or "" for choice in action._choices_actions}
            return [(name, helps.get(name, ""), sub) for name, sub in action.choices.items()]
    return []


def command_reference() -> str:
    """``infoseek --help`` and every subcommand's ``--help``, as the command prints them."""
    from infoseek.experiments.cli import build_parser

    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal width
    try:
        parser = build_parser()
        parts = ["```text\n" + parser.format_help() + "```\n"]
        for name, help_text, subparser in _subcommands(parser):
            parts.append(f"## `infoseek {name}`\n\n{help_text.capitalize()}.\n")
            parts.append("```text\n" + subparser.format_help() + "```\n")
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous
    return "\n".join(parts)


def expand(text: str) -> str:
    """Every marker of a page replaced by what it stands for."""

    def replace(match: re.Match[str]) -> str:
        kind, argument = match.group(1), match.group(2)
        if kind == "docstring":
            return markdown_docstring(argument)
        if kind == "api":
            return api_reference(argument)
        if kind == "apimodule":
            return module_api(argument)
        if kind == "modules":
            return modules_reference(argument)
        if kind == "cli":
            return command_reference()
        raise ValueError(f"unknown infoseek marker {kind!r}")

    return MARKER.sub(replace, text)


def _source_read(app: Sphinx, docname: str, source: list[str]) -> None:
    source[0] = expand(source[0])


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("source-read", _source_read)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
