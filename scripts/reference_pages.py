"""docs/reference/*.md: one page per package with a public ``__all__``, generated so it covers every public name.

    python scripts/reference_pages.py        # rewrites docs/reference/

Each page is mkdocstrings' ``::: bim2rdt.PACKAGE`` (the names the package binds itself), plus one
``::: home.module.NAME`` block for each name the package exports lazily (PEP 562 ``__getattr__``), which a static
reader cannot follow. tests/test_docs.py checks that the pages are what this script writes.
"""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOURCE = ROOT / "src" / "bim2rdt"
REFERENCE = ROOT / "docs" / "reference"
MODULES = ("errors", "atomic", "config")
"""Single-module parts of the public API, documented whole."""


def packages() -> list[str]:
    """Packages whose ``__init__`` declares ``__all__``, in name order."""
    return sorted(path.parent.name for path in SOURCE.glob("*/__init__.py") if "__all__" in path.read_text())


def statically_bound(init: Path) -> set[str]:
    """Names an ``__init__`` binds at module level (imports, assignments, definitions)."""
    bound = set()
    for node in ast.parse(init.read_text()).body:
        if isinstance(node, ast.ImportFrom | ast.Import):
            bound.update((alias.asname or alias.name).split(".")[0] for alias in node.names)
        elif isinstance(node, ast.FunctionDef | ast.ClassDef):
            bound.add(node.name)
        elif isinstance(node, ast.Assign):
            bound.update(target.id for target in node.targets if isinstance(target, ast.Name))
    return bound


def lazy_homes(package: str) -> dict[str, str]:
    """{public name: the module that defines it} for names of ``__all__`` the package resolves lazily."""
    module = importlib.import_module(f"bim2rdt.{package}")
    bound = statically_bound(SOURCE / package / "__init__.py")
    homes = {}
    for name in module.__all__:
        if name in bound:
            continue
        homes_table = getattr(module, "_HOMES", {})
        home = f"bim2rdt.{package}.{homes_table[name]}" if name in homes_table else getattr(module, name).__module__
        homes[name] = home
    return homes


def page(package: str) -> str:
    lines = [f"# bim2rdt.{package}", "", f"::: bim2rdt.{package}", ""]
    for name, home in sorted(lazy_homes(package).items()):
        lines += [f"::: {home}.{name}", "    options:", "      show_root_heading: true", ""]
    return "\n".join(lines)


def index(names: list[str]) -> str:
    lines = ["# Reference", "", "Generated from the docstrings of each package's public names (its `__all__`) by",
             "`python scripts/reference_pages.py`. The command line is documented by `bim2rdt COMMAND --help`.", ""]
    return "\n".join(lines + [f"- [bim2rdt.{name}]({name}.md)" for name in names]) + "\n"


def pages() -> dict[str, str]:
    """{file name: text} of every reference page."""
    names = [*MODULES, *packages()]
    written = {f"{name}.md": f"# bim2rdt.{name}\n\n::: bim2rdt.{name}\n" for name in MODULES}
    written.update({f"{name}.md": page(name) for name in packages()})
    written["index.md"] = index(names)
    return written


def main() -> None:
    sys.path.insert(0, str(ROOT / "src"))
    REFERENCE.mkdir(parents=True, exist_ok=True)
    for name, text in pages().items():
        (REFERENCE / name).write_text(text)
    print(REFERENCE)


if __name__ == "__main__":
    main()
