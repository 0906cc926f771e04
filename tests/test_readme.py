"""Every code block of README.md and of the documentation pages (docs/**/*.md) runs (issue 28:
the make_vec + PPO snippet failed as a script).

* ``python`` blocks are run as scripts (``python FILE``, so a block that starts worker
  processes without an ``if __name__ == "__main__":`` guard fails as it would for a reader), at
  small sizes: :data:`SMALLER` lists, per block, the replacements that shrink it, and each must
  apply (a README edit that drops one fails here, so the table never goes stale silently).
* ``bash`` blocks and every ``infoseek ...`` command quoted in the text are parsed by the
  ``infoseek`` argument parser (an option that does not exist, a value of the wrong type); the
  Quickstart's test command is checked against CI in ``tests/test_packaging.py``.
* ``text`` blocks are printed output and ``bibtex`` a citation: not run; ``{toctree}``,
  ``{eval-rst}`` and ``{include}`` are the documentation's Sphinx directives (built by
  ``.ci/docs``).
"""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from infoseek.experiments.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
#: The README and every page of the documentation's sources.
DOCUMENTS = {
    path.relative_to(ROOT).as_posix(): path.read_text()
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    if "_build" not in path.parts
}
#: A fenced block: indentation, language (or a MyST directive such as ``{include}``, whose
#: argument may follow it on the fence line) and body.
BLOCK = re.compile(r"^( *)```([\w{}-]+)[^\n`]*\n(.*?)^\1```", re.MULTILINE | re.DOTALL)

#: First line of a python block -> (text, smaller text) replacements that make it fast.
SMALLER: dict[str, list[tuple[str, str]]] = {
    "import infoseek.envs": [
        ("belief_in_infos=True)", "belief_in_infos=True, n_particles=200, max_cycles=3)"),
    ],
    "from stable_baselines3 import PPO": [
        ("num_envs=16, n_workers=2)", "num_envs=2, n_workers=2, n_particles=100, max_cycles=4)"),
        ('PPO("MlpPolicy", venv)', 'PPO("MlpPolicy", venv, n_steps=8, batch_size=16)'),
        ("learn(100_000)", "learn(64)"),
    ],
}
KNOWN_LANGUAGES = {"python", "bash", "text", "bibtex", "{toctree}", "{eval-rst}", "{include}"}


def _blocks(language: str) -> list[str]:
    """The blocks of ``language`` in every document, each once (the README's example is also
    the getting-started page's)."""
    blocks = [
        "\n".join(line[len(indent) :] for line in body.splitlines())
        for text in DOCUMENTS.values()
        for indent, lang, body in BLOCK.findall(text)
        if lang == language
    ]
    return list(dict.fromkeys(blocks))


def test_the_documents_include_the_readme_and_the_docs() -> None:
    assert "README.md" in DOCUMENTS and "docs/index.md" in DOCUMENTS


@pytest.mark.parametrize("name", DOCUMENTS)
def test_every_block_has_a_known_language(name: str) -> None:
    text = DOCUMENTS[name]
    languages = {lang for _, lang, _ in BLOCK.findall(text)}
    assert languages <= KNOWN_LANGUAGES, languages - KNOWN_LANGUAGES
    assert text.count("```") == 2 * len(BLOCK.findall(text))  # no unterminated block


@pytest.mark.parametrize("code", _blocks("python"), ids=lambda code: code.splitlines()[0])
def test_python_blocks_run_as_scripts(code: str, tmp_path: Path) -> None:
    first = code.splitlines()[0]
    assert first in SMALLER, f"add the block starting {first!r} to SMALLER"
    for text, smaller in SMALLER[first]:
        assert text in code, f"{text!r} is no longer in the block starting {first!r}"
        code = code.replace(text, smaller)
    script = tmp_path / "snippet.py"
    script.write_text(code)
    run = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr[-3000:]


def _quoted_commands() -> list[str]:
    """``infoseek ...`` commands of bash blocks and inline code outside tables, each once."""
    commands = []
    for block in _blocks("bash"):
        for part in re.split(r"&&|\n", block):
            if part.strip().startswith("infoseek "):
                commands.append(part.strip())
    for text in DOCUMENTS.values():
        prose = BLOCK.sub("", text)
        for line in prose.splitlines():
            if line.lstrip().startswith("|"):
                continue  # tables show synopses with [optional] parts and alternatives
            commands += [c for c in re.findall(r"`(infoseek [^`]+)`", line)]
    return list(dict.fromkeys(commands))


#: Placeholders the prose uses for a reader's own values, as parsable stand-ins.
PLACEHOLDERS = {"DIR": "results", "OUT": "out", "OLD": "old", "NEW": "new", "N": "3"}


def _options(command: str) -> set[str]:
    choices = next(
        action.choices
        for action in build_parser()._actions
        if isinstance(action, argparse._SubParsersAction)
    )
    return {option for action in choices[command]._actions for option in action.option_strings}


@pytest.mark.parametrize("command", _quoted_commands())
def test_quoted_commands_parse(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    """A whole command parses; a mention (``infoseek train --features egocentric`` in a
    sentence, without the arguments a run needs) names a command and options that exist."""
    words = [PLACEHOLDERS.get(word, word) for word in shlex.split(command)[1:]]
    try:
        build_parser().parse_args(words)
    except SystemExit as exit_:  # argparse reports the problem on stderr
        if exit_.code == 0 and "--help" in words:
            return  # the help was printed
        error = capsys.readouterr().err
        if "the following arguments are required" not in error:
            pytest.fail(f"{command!r} does not parse (exit {exit_.code}): {error}")
        unknown = {w.split("=")[0] for w in words if w.startswith("--")} - _options(words[0])
        assert not unknown, f"{command!r}: no option(s) {sorted(unknown)}"


def test_there_are_commands_to_check() -> None:
    assert len(_quoted_commands()) > 20
