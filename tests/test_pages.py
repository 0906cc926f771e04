"""The results pages (docs/results/*.md) are what their writers make of the committed results
(:mod:`infoseek.experiments.pages`), so a page cannot drift from its store; a page follows its
store's data; the provenance says what the manifest records, and only that."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from infoseek.experiments.cli import main
from infoseek.experiments.pages.provenance import provenance_section, read_provenance
from infoseek.experiments.pages.registry import PAGES, render_page
from infoseek.experiments.store import ResultsStore, read_manifest, read_rows

ROOT = Path(__file__).resolve().parents[1]
RL_STORE = ROOT / "experiments/results/rl/bench_20_steps"
SHIPPED = "policy:shipped/ppo_bearings_v0_4agents"


@pytest.mark.parametrize("name", sorted(PAGES))
def test_committed_page_is_what_its_results_give(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Regenerating each page from the committed results gives the committed page, byte for
    byte (run from the repository's root, as ``infoseek page NAME`` is)."""
    page = PAGES[name]
    monkeypatch.chdir(ROOT)
    committed = page.default_page.read_text()
    assert render_page(name, page.default_results, page.default_page) == committed, (
        f"docs/results/{name}.md differs from what its results give: run `infoseek page {name}`"
    )


def _copy_store(destination: Path, trials: int, changed: int) -> list[dict]:
    """Trials ``0..trials-1`` of every group of the committed RL bench store, copied through
    the store API, the shipped policy's trials ``0..changed-1`` localised from their first step
    on (mass 1 at every step); returns the copied rows."""
    rows = [row for row in read_rows(RL_STORE) if row["trial"] < trials]
    copied = []
    for row in rows:
        if row["planner"] == SHIPPED and row["trial"] < changed:
            row = {**row, "mass_agent0": [1.0] * len(row["mass_agent0"])}
        copied.append(row)
    with ResultsStore(destination, read_manifest(RL_STORE)["config"]) as store:
        for row in copied:
            store.append(row)
    return copied


def test_a_page_follows_its_store(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Changing stored trials of one group moves the page's number for that group to the mean
    computed here from the rows, and leaves the other groups' numbers."""
    monkeypatch.chdir(ROOT)
    results = tmp_path / "rl"
    _copy_store(results / "bench_20_steps", trials=40, changed=0)
    before = render_page("rl", results, tmp_path / "page.md")
    shutil.rmtree(results / "bench_20_steps")
    rows = _copy_store(results / "bench_20_steps", trials=40, changed=10)
    after = render_page("rl", results, tmp_path / "page.md")
    finals = [row["mass_agent0"][-1] for row in rows if row["planner"] == SHIPPED]
    expected = f"| `policy ppo_bearings_v0_4agents` | {np.mean(finals):.3f} |"
    assert expected in after
    assert expected not in before
    single = [row["mass_agent0"][-1] for row in rows if row["planner"] == "single"]
    assert f"| `single` | {np.mean(single):.3f} |" in before
    assert f"| `single` | {np.mean(single):.3f} |" in after


def test_provenance_reports_a_recorded_run_and_admits_a_missing_one(tmp_path: Path) -> None:
    """A store without runs says the machine is not known; one with a run names its machine
    and wall time, as recorded."""
    _copy_store(tmp_path / "store", trials=200, changed=0)  # written through the API: no run
    section = provenance_section(read_provenance(tmp_path / "store"))
    assert "machine and the wall-clock time of the commands that wrote it are not known" in section
    machine = {"cpu": "Test CPU", "cpus": 3, "memory_gib": 5.0, "system": "OS", "python": "3.x"}
    with ResultsStore(tmp_path / "store", read_manifest(RL_STORE)["config"]) as store:
        store.record_run(
            {
                "trials": 7,
                "wall_time": 90.0,
                "backend": "serial",
                "workers": 1,
                "machine": machine,
                "version": "0",
            }
        )
    section = provenance_section(read_provenance(tmp_path / "store"))
    assert "7 trials in 90.0 s of wall-clock time" in section
    assert "Test CPU, 3 logical CPU(s), 5 GiB" in section
    assert "not known" not in section
    walls = sum(row["wall_time"] for row in read_rows(tmp_path / "store"))
    assert f"{walls / 3600:.2f} h in all" in section or f"{walls / 60:.1f} min in all" in section


def test_page_command_writes_the_page_and_refuses_a_missing_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``infoseek page`` writes the page it renders; a missing results directory is a one-line
    error with exit 2 and nothing written."""
    monkeypatch.chdir(ROOT)
    results = tmp_path / "rl"
    shutil.copytree(RL_STORE, results / "bench_20_steps")
    out = tmp_path / "pages" / "rl.md"
    assert main(["page", "rl", "--results", str(results), "--out", str(out)]) == 0
    assert out.read_text() == render_page("rl", results, out)
    missing = tmp_path / "nothing.md"
    code = main(["page", "rl", "--results", str(tmp_path / "absent"), "--out", str(missing)])
    assert code == 2 and not missing.exists()
    assert "no such directory" in capsys.readouterr().err


def test_every_page_is_listed_and_links_its_figure() -> None:
    """Every page of docs/results except the index is a registered page, and every image it
    shows exists (paths relative to the page)."""
    pages = {path.stem for path in (ROOT / "docs/results").glob("*.md")} - {"index"}
    assert pages == set(PAGES)
    for name in PAGES:
        text = (ROOT / "docs/results" / f"{name}.md").read_text()
        for target in (
            line.split("](", 1)[1].rstrip(")")
            for line in text.splitlines()
            if line.startswith("![")
        ):
            assert (ROOT / "docs/results" / target).resolve().exists(), (name, target)


def test_reproduce_writes_its_page(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``infoseek reproduce fig2 --page FILE`` ends by writing the page of what it ran, with
    the snapshot masses of the record it kept."""
    monkeypatch.chdir(tmp_path)
    argv = ["reproduce", "fig2", "--steps", "2", "--particles", "100", "--out", "out"]
    assert main([*argv, "--page", "docs/fig2.md"]) == 0
    page = (tmp_path / "docs/fig2.md").read_text()
    assert page == render_page("fig2", Path("out"), Path("docs/fig2.md"))
    record = json.loads((tmp_path / "out/fig2.json").read_text())
    for step, mass in record["snapshot_masses"].items():
        assert f"| {step} | {mass:.3f} |" in page
    assert "![Fig. 2 reproduction](../out/fig2.png)" in page


#: A number as the documents quote results: ``21.11``, ``3.3 %``, ``+0.59``.
_NUMBER = re.compile(r"(?<![\w.])[+-]?\d+\.\d+(?![\w.])")
_PAGE_LINK = re.compile(r"results/(\w+)\.md")
_FIGURE = re.compile(r"experiments/results/(\w+)/\w+\.png")


def _quoting_paragraphs() -> list[tuple[str, str, str]]:
    """``(document, paragraph, page)`` for every paragraph or list item outside
    ``docs/results/`` that quotes a decimal number and names a results page (a link to it, or its
    figure just above). The Performance page is left out: its numbers are timings, each with the
    ``infoseek timing`` command that measured it, not study results."""
    documents = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    found = []
    for path in documents:
        name = path.relative_to(ROOT).as_posix()
        if name.startswith("docs/results/") or name == "docs/performance.md":
            continue
        figure_page = None
        for paragraph in re.split(r"\n\s*\n|\n(?=\* )", path.read_text()):
            figure = _FIGURE.search(paragraph)
            if figure:
                figure_page = figure.group(1)
            pages = [p for p in _PAGE_LINK.findall(paragraph) if p != "index"] or (
                [figure_page] if figure_page and not paragraph.startswith(("|", "#")) else []
            )
            if pages and _NUMBER.search(paragraph) and not paragraph.lstrip().startswith("|"):
                found.append((name, paragraph, pages[0]))
    return found


def test_results_quoted_outside_the_results_pages_are_on_their_page() -> None:
    """A results number quoted in the README or another docs page (the Fig. 1 summary, the
    horizon planner's gains) is the number the results page it points to prints: it cannot
    outlive a regenerated page."""
    quoting = _quoting_paragraphs()
    assert {document for document, _, _ in quoting} >= {"README.md", "docs/planners.md"}
    for document, paragraph, page in quoting:
        text = (ROOT / "docs" / "results" / f"{page}.md").read_text()
        missing = [n.lstrip("+") for n in _NUMBER.findall(paragraph) if n.lstrip("+") not in text]
        assert not missing, f"{document} quotes {missing}, which docs/results/{page}.md lacks"


def test_fig2_page_quotes_the_step_20_distribution_of_the_beacon_study() -> None:
    """Issue 29: Fig. 2's one-episode mass is not stable; its page gives the distribution over
    the beacon study's pairwise-node n_v = 4 episodes, recomputed here from the store's rows."""
    rows = read_rows(ROOT / "experiments/results/beacon/store")
    masses = np.array(
        [r["mass_agent0"][20] for r in rows if (r["planner"], r["n_agents"]) == ("pairwise", 4)]
    )
    assert masses.size >= 200
    text = (ROOT / "docs/results/fig2.md").read_text()
    q25, median, q75 = np.quantile(masses, [0.25, 0.5, 0.75])
    row = f"| {masses.size} | {masses.mean():.3f} | {median:.3f} ({q25:.3f} - {q75:.3f}) |"
    assert row in text


def _ttl_and_off_target(store: Path) -> tuple[int, float, int, int]:
    """Trials, mean censored time to localise, trials never localised and trials whose last
    MMSE error exceeds the radius, recomputed from a store's raw rows."""
    steps = int(read_manifest(store)["config"]["steps"])
    rows = list(read_rows(store))
    times = [next((t for t, m in enumerate(row["mass_agent0"]) if m >= 0.9), steps) for row in rows]
    never = sum(all(m < 0.9 for m in row["mass_agent0"]) for row in rows)
    off = sum(row["error_agent0"][-1] > row["radius"] for row in rows)
    return len(rows), float(np.mean(times)), never, off


def test_beacon_particles_page_times_are_those_of_its_stores() -> None:
    """Each particle count's mean time to localise, never-localised and off-target counts on
    the page, recomputed here from its store's rows (first step with agent 0's mass >= 0.9,
    censored at the episode length; last MMSE error beyond the radius)."""
    text = (ROOT / "docs/results/beacon_particles.md").read_text()
    stores = sorted((ROOT / "experiments/results/beacon_particles").glob("n*/manifest.json"))
    assert len(stores) >= 3
    for manifest in stores:
        n, mean, never, off = _ttl_and_off_target(manifest.parent)
        particles = manifest.parent.name[1:]
        row = f"| {particles} | {n} | {mean:.2f} ("
        assert row in text, particles
        assert f" | {never} of {n} | {off} of {n} | " in text.split(row, 1)[1].split("\n")[0]


def test_beacon_filter_page_rows_are_those_of_its_stores() -> None:
    """Each filter setting's row on the page (the single-node settings and the pairwise-node
    checks): its options (from the store's manifest), mean time to localise, never-localised and
    off-target counts, recomputed from the raw rows."""
    text = (ROOT / "docs/results/beacon_filter.md").read_text()
    results = ROOT / "experiments/results/beacon_filter"
    stores = sorted(results.glob("*/manifest.json")) + sorted(
        results.glob("pairwise/*/manifest.json")
    )
    assert len(stores) >= 2
    for manifest in stores:
        options = read_manifest(manifest.parent)["config"]["env_kwargs"]
        n, mean, never, off = _ttl_and_off_target(manifest.parent)
        label = ", ".join(f"`{k}={json.dumps(v)}`" for k, v in sorted(options.items()))
        row = f"| {label or 'defaults (reference)'} | {n} | {mean:.2f} ("
        assert row in text, manifest.parent.name
        assert f" | {never} of {n} | {off} of {n} | " in text.split(row, 1)[1].split("\n")[0]
