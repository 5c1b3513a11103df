"""Library packages import each other only through their ``__all__`` (STYLE.md practice 11): ``from
bim2rdt.perception import Frame``, never ``from bim2rdt.perception.frame import Frame`` nor a name the package
does not export. Checked on the source's import statements (module level and inside functions), as
``test_layers.py`` checks the layers; a planted private import fails it."""

from __future__ import annotations

import ast
import importlib
import shutil
from pathlib import Path

import bim2rdt

PACKAGE = Path(bim2rdt.__file__).parent
NOT_LIBRARY = {"cli", "demo", "bench", "sim", "evaluation"}
"""The edge and the simulator: they may reach into the library's modules (the layers still bind them)."""

def library_packages() -> set[str]:
    return {p.parent.name for p in PACKAGE.glob("*/__init__.py")} - NOT_LIBRARY


def exported() -> dict[str, set[str]]:
    """{package: its ``__all__``}."""
    return {name: set(getattr(importlib.import_module(f"bim2rdt.{name}"), "__all__", ()))
            for name in library_packages()}


def private_imports(package_dir: Path, exports: dict[str, set[str]]) -> set[str]:
    """Each import in a library package of another library package's module, or of a name it does not export,
    as ``"importer -> module.name"`` (package-relative, no line numbers: moving code keeps its entry)."""
    found = set()
    for path in sorted(package_dir.rglob("*.py")):
        parts = path.relative_to(package_dir).with_suffix("").parts
        if len(parts) < 2 or parts[0] not in exports:
            continue
        importer = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("bim2rdt."):
                module = node.module.split(".")[1:]
                if module[0] not in exports or module[0] == parts[0]:
                    continue
                for alias in node.names:
                    if len(module) > 1 or alias.name not in exports[module[0]]:
                        found.add(f"{importer} -> {'.'.join(module)}.{alias.name}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    module = alias.name.split(".")[1:]
                    if alias.name.startswith("bim2rdt.") and len(module) > 1 and module[0] in exports \
                            and module[0] != parts[0]:
                        found.add(f"{importer} -> {'.'.join(module)}")
    return found


def test_library_packages_import_each_other_only_through_their_all():
    new = private_imports(PACKAGE, exported())
    assert not new, "private cross-package imports (make the name public in its package's __all__, with a " \
                    "docstring, and import it from the package):\n" + "\n".join(sorted(new))


def test_a_planted_private_import_is_refused(tmp_path):
    shutil.copytree(PACKAGE, tmp_path / "bim2rdt", ignore=shutil.ignore_patterns("__pycache__"))
    chain = tmp_path / "bim2rdt" / "verify" / "chain.py"
    chain.write_text(chain.read_text() + "\nfrom bim2rdt.localization.cloud import OccludedMap  # noqa: E402,F401\n"
                     "\n\ndef _f():\n    from bim2rdt.perception import background  # noqa: F401\n")
    found = private_imports(tmp_path / "bim2rdt", exported())
    assert found == {"verify.chain -> localization.cloud.OccludedMap", "verify.chain -> perception.background"}
