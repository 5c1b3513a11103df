"""The docs site cannot drift: it builds with ``mkdocs build --strict`` (a broken link or reference fails), the
reference shows every public name of every package, and the benchmarks page is what the saved runs give."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
REFERENCE = ROOT / "docs" / "reference"


def packages_with_public_names() -> list[str]:
    source = ROOT / "src" / "bim2rdt"
    names = [path.parent.name for path in source.glob("*/__init__.py")
             if "__all__" in path.read_text(encoding="utf-8")]
    return sorted(names)


@pytest.fixture(scope="module")
def built_site(tmp_path_factory) -> Path:
    site = tmp_path_factory.mktemp("site")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "NO_MKDOCS_2_WARNING": "1"}
    # no -q: mkdocs counts warnings for --strict only at the WARNING log level
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
                           "-d", str(site)], capture_output=True, text=True, env=env, cwd=ROOT, timeout=300)
    assert done.returncode == 0, f"mkdocs build --strict failed:\n{done.stdout}\n{done.stderr}"
    return site


def scripts_module(name: str):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(ROOT / "scripts"))


def test_the_reference_pages_are_what_the_generator_writes_and_the_index_links_each():
    expected = scripts_module("reference_pages").pages()
    assert sorted(path.name for path in REFERENCE.glob("*.md")) == sorted(expected)
    stale = [name for name, text in expected.items() if (REFERENCE / name).read_text(encoding="utf-8") != text]
    assert not stale, f"run `python scripts/reference_pages.py`: {stale}"
    assert not [name for name in expected if name != "index.md" and f"]({name})" not in expected["index.md"]]


def test_the_reference_shows_every_name_in_each_packages_all(built_site):
    missing = []
    for name in packages_with_public_names():
        page = (built_site / "reference" / name / "index.html").read_text(encoding="utf-8")
        shown = set(re.findall(r'id="(bim2rdt\.[A-Za-z0-9_.]+)"', page))
        homes = scripts_module("reference_pages").lazy_homes(name)
        missing += [f"bim2rdt.{name}.{public}" for public in importlib.import_module(f"bim2rdt.{name}").__all__
                    if f"bim2rdt.{name}.{public}" not in shown and f"{homes.get(public)}.{public}" not in shown]
    assert not missing, f"public names the reference does not show: {missing}"


def test_the_guide_pages_are_built(built_site):
    for page in ("guide/demo", "guide/sources", "concepts/architecture", "benchmarks", "decisions"):
        assert (built_site / page / "index.html").exists(), page


def test_the_decisions_index_lists_every_record():
    expected = scripts_module("reference_pages").decisions_index()
    assert (ROOT / "docs" / "decisions" / "index.md").read_text(encoding="utf-8") == expected, \
        "run `python scripts/reference_pages.py`"
    assert expected.count("- [") == len(list((ROOT / "docs" / "decisions").glob("[0-9]*.md")))


def test_the_benchmarks_page_is_what_the_saved_runs_give():
    benchmarks_page = scripts_module("benchmarks_page")
    runs = sorted((ROOT / "docs" / "benchmarks").glob("*.json"))
    assert runs, "no saved benchmark runs in docs/benchmarks/"
    page = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    assert page == benchmarks_page.render(), "run `python scripts/benchmarks_page.py render`"
    for run in runs:
        assert f"## {run.stem}\n" in page


def architecture_layers(page: str) -> list[str]:
    """The numbered list of the architecture page's "Layers" section: each item's first code span, top down."""
    section = page.split("\n## Layers", 1)[1].split("\n## ", 1)[0]
    return [match.group(1) for match in re.finditer(r"^\d+\. `([^`]+)`", section, flags=re.M)]


def importlinter_layers(text: str) -> list[str]:
    """The ``layers =`` lines of .importlinter's layers contract, top down."""
    block = text.split("layers =\n", 1)[1]
    return [line.strip() for line in block.splitlines() if line.startswith((" ", "\t")) and line.strip()]


def test_the_architecture_pages_layers_are_the_import_contracts_layers():
    page = (ROOT / "docs" / "concepts" / "architecture.md").read_text(encoding="utf-8")
    contract = importlinter_layers((ROOT / ".importlinter").read_text(encoding="utf-8"))
    assert contract[:2] == ["__main__", "cli"] and contract[-1] == "errors"
    assert architecture_layers(page) == contract


def test_the_architecture_page_is_built_and_links_into_the_reference(built_site):
    html = (built_site / "concepts" / "architecture" / "index.html").read_text(encoding="utf-8")
    assert "Registration: what the loop minimises" in html
    assert 'href="../../reference/safety/"' in html
