"""The repository layout and the one-way dependency rule of DEVELOPERS.md."""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["envs", "planners", "baselines", "experiments"]  # lower layers first


def _pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def _package_folders() -> list[Path]:
    folders = []
    for layer in LAYERS:
        for init in sorted((ROOT / layer).rglob("__init__.py")):
            folders.append(init.parent.relative_to(ROOT))
    return folders


def test_every_package_folder_is_listed_in_pyproject() -> None:
    setuptools_cfg = _pyproject()["tool"]["setuptools"]
    package_dir = setuptools_cfg["package-dir"]
    packages = set(setuptools_cfg["packages"])
    assert _package_folders(), "no package folders found"
    for folder in _package_folders():
        name = "infoseek." + ".".join(folder.parts)
        assert name in packages, f"{folder} is not listed as {name} in pyproject packages"
        assert Path(package_dir[name]) == folder, f"{name} must map to {folder}"
    for name, path in package_dir.items():
        assert (ROOT / path / "__init__.py").is_file(), f"{name} -> {path} has no __init__.py"


def test_every_layer_ships_py_typed() -> None:
    for layer in LAYERS:
        assert (ROOT / layer / "py.typed").is_file(), f"{layer}/py.typed is missing"


def _imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.parametrize("layer", LAYERS)
def test_dependencies_point_one_way(layer: str) -> None:
    higher = LAYERS[LAYERS.index(layer) + 1 :]
    for path in sorted((ROOT / layer).rglob("*.py")):
        for module in _imported_modules(path):
            parts = module.split(".")
            assert parts[0] not in LAYERS, (
                f"{path.relative_to(ROOT)} imports bare {module!r}; use infoseek.{module}"
            )
            if parts[0] == "infoseek" and len(parts) > 1:
                assert parts[1] not in higher, (
                    f"{path.relative_to(ROOT)} imports {module}: {layer} must not import upward"
                )


#: The top layer of experiments/: what combines studies (the command line, the results pages).
EXPERIMENTS_TOP = {"cli.py", "reproduce.py", "launch.py", "__main__.py"}
STUDIES = "infoseek.experiments.studies"


def _study_imports(source: str, package: str) -> set[str]:
    """The studies (module names in ``experiments/studies/``) that ``source``, a module of the
    package ``package``, imports: absolute or relative, ``import``, ``from ... import`` of a
    study or of the studies package itself (``"*"``: the whole subpackage)."""
    found: set[str] = set()

    def add(module: str, names: list[str]) -> None:
        if module == STUDIES:
            found.update(names or ["*"])
        elif module.startswith(STUDIES + "."):
            found.add(module[len(STUDIES) + 1 :].split(".")[0])
        elif module == "infoseek.experiments" and "studies" in names:
            found.add("*")

    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name, [])
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join([*base, module] if module else base)
            add(module, [alias.name for alias in node.names])
    return found


def test_the_study_import_detector_finds_every_form() -> None:
    assert _study_imports("from infoseek.experiments.studies import fig1, claims", "x") == {
        "fig1",
        "claims",
    }
    assert _study_imports("import infoseek.experiments.studies.ablation as a", "x") == {"ablation"}
    assert _study_imports("from infoseek.experiments.studies.fig2 import f", "x") == {"fig2"}
    assert _study_imports("from infoseek.experiments import studies", "x") == {"*"}
    assert _study_imports("from . import beacon", STUDIES) == {"beacon"}
    assert _study_imports("from .claims import f", STUDIES) == {"claims"}
    assert _study_imports("from .studies.fig1 import p", "infoseek.experiments") == {"fig1"}
    assert _study_imports("from infoseek.experiments.bench import BenchPlan", "x") == set()


def test_no_study_imports_another_and_the_harness_imports_no_study() -> None:
    """experiments/studies/__init__.py: a study imports the harness and the analysis, never
    another study; no module of experiments/ below the top layer (the command line and the
    results pages, which combine studies) imports a study."""
    studies = ROOT / "experiments" / "studies"
    names = {path.stem for path in studies.glob("*.py")} - {"__init__"}
    assert {"fig1", "fig2", "beacon", "ablation", "decisions", "claims"} <= names
    for path in sorted(studies.glob("*.py")):
        imported = _study_imports(path.read_text(), STUDIES)
        allowed = {path.stem} if path.stem in names else set()
        assert imported <= allowed, f"studies/{path.name} imports the studies {imported}"
    for path in sorted((ROOT / "experiments").glob("*.py")):
        if path.name in EXPERIMENTS_TOP:
            continue
        imported = _study_imports(path.read_text(), "infoseek.experiments")
        assert not imported, f"experiments/{path.name} imports the studies {imported}"


def _quickstart() -> tuple[list[str], str]:
    """The Quickstart's bash lines and the prose after them (up to the next section)."""
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Quickstart", 1)[1].split("\n## ", 1)[0]
    block = section.split("```bash\n", 1)[1].split("```", 1)[0]
    return block.strip().splitlines(), section


def test_test_command_of_readme_is_what_ci_runs() -> None:
    lines, prose = _quickstart()
    test_command = lines[1]
    assert test_command.endswith('pip install -e ".[test]" && pytest')
    ci = [
        line.strip()
        for line in (ROOT / ".ci" / "run").read_text().splitlines()
        if line.strip() and not line.startswith(("#", "set ", "cd ", "python -m pip install"))
    ]
    assert test_command in ci
    # CI adds exactly what the Quickstart says it adds, and nothing else
    for added in (line for line in ci if line != test_command):
        assert f"`{added}`" in prose, f"the Quickstart does not say that CI runs {added!r}"


def test_quickstart_installs_the_cpu_build_of_torch_before_the_test_extra() -> None:
    """An unpinned torch from PyPI is the CUDA build (torch + triton + nvidia-* + cuda-*:
    6.4 GB on a machine without a GPU); the CPU wheel must be installed in the same command,
    before the test extra pulls torch."""
    cpu_index = "--extra-index-url https://download.pytorch.org/whl/cpu"
    test_command = _quickstart()[0][1]
    torch_install = test_command.split(" && ")[0]
    assert torch_install.startswith('pip install "torch==') and torch_install.endswith(cpu_index)
    assert test_command.index(cpu_index) < test_command.index('pip install -e ".[test]"')
    ci_first = (ROOT / ".ci" / "run").read_text().split("python -m pip install --quiet ", 1)[1]
    assert "pip install " + ci_first.splitlines()[0] == torch_install  # CI's first step


def test_license_and_citation_agree_with_pyproject() -> None:
    project = _pyproject()["project"]
    assert project["license"] == "MIT"  # an SPDX expression (PEP 639), not the old table
    assert project["license-files"] == ["LICENSE"]
    licence = (ROOT / "LICENSE").read_text()
    assert licence.startswith("MIT License") and "WITHOUT WARRANTY OF ANY KIND" in licence
    fields = {}
    for line in (ROOT / "CITATION.cff").read_text().splitlines():
        if line and not line.startswith((" ", "-", "#")) and ":" in line:
            key, _, value = line.partition(":")
            fields[key] = value.strip().strip('"')
    assert fields["cff-version"] == "1.2.0"
    assert fields["license"] == "MIT" and fields["version"] == project["version"]
    assert "title" in fields and "preferred-citation" in fields
