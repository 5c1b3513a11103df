"""The public API's docstrings match the code: every class and function a package exports (its ``__all__``), every
public method of those classes, and every public name of the single-module parts (errors, atomic, config) has a
docstring, and pydoclint (configured in pyproject.toml's ``[tool.pydoclint]``: Google style) finds its Args,
Returns and Raises sections consistent with the signature and the body."""

from __future__ import annotations

import ast
import importlib
import inspect
import logging
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOURCE = ROOT / "src" / "bim2rdt"
MODULES = ("errors", "atomic", "config")
"""Single-module parts of the public API: every public class and function they define is public."""
VIOLATION = re.compile(r"^\s*\d+: (DOC\d+): (?:Function|Method|Class) `([^`]+)`")
RAISES_MISMATCH = re.compile(r"in the docstring: \[(.*?)\]\. Raised exceptions in the body: \[(.*?)\]")
RE_RAISED = {"BaseException", "Exception"}
"""What a bare ``raise`` after ``except BaseException:`` (clean up, then let anything through) reports: not an
exception the function raises, so Raises need not name it."""


def packages() -> list[str]:
    return sorted(path.parent.name for path in SOURCE.glob("*/__init__.py")
                  if "__all__" in path.read_text(encoding="utf-8"))


def module_file(module: str) -> Path:
    return ROOT / "src" / Path(*module.split(".")).with_suffix(".py")


def exported_homes() -> dict[Path, set[str]]:
    """{module file: top-level names it defines that the public API exports}."""
    homes: dict[Path, set[str]] = {}
    for package in packages():
        module = importlib.import_module(f"bim2rdt.{package}")
        for name in module.__all__:
            thing = getattr(module, name)
            if inspect.isclass(thing) or inspect.isfunction(thing):
                homes.setdefault(module_file(thing.__module__), set()).add(thing.__qualname__)
    for name in MODULES:
        path = SOURCE / f"{name}.py"
        defined = {node.name for node in ast.parse(path.read_text(encoding="utf-8")).body
                   if isinstance(node, ast.FunctionDef | ast.ClassDef) and not node.name.startswith("_")}
        homes.setdefault(path, set()).update(defined)
    return homes


def public_definitions(path: Path, names: set[str]) -> dict[str, ast.AST]:
    """{qualified name: definition} of the named top-level classes and functions in a module, and of the public
    methods (and ``__init__``) of those classes."""
    found: dict[str, ast.AST] = {}
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if not isinstance(node, ast.FunctionDef | ast.ClassDef) or node.name not in names:
            continue
        found[node.name] = node
        if isinstance(node, ast.ClassDef):
            for member in node.body:
                if isinstance(member, ast.FunctionDef) and (not member.name.startswith("_")
                                                            or member.name == "__init__"):
                    found[f"{node.name}.{member.name}"] = member
    return found


def public_api() -> dict[Path, dict[str, ast.AST]]:
    return {path: public_definitions(path, names) for path, names in sorted(exported_homes().items())}


def pydoclint_violations(paths: list[Path]) -> dict[tuple[Path, str], list[str]]:
    """{(module file, qualified name): [violation lines]} as pydoclint, with the project's configuration, reports
    them."""
    done = subprocess.run([str(Path(sys.executable).parent / "pydoclint"), "-q", "--config", str(ROOT / "pyproject.toml"),
                           "--show-filenames-in-every-violation-message", "false", *map(str, paths)],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode in (0, 1) and "Traceback" not in done.stderr, done.stderr[-2000:]
    violations: dict[tuple[Path, str], list[str]] = {}
    current = None
    for line in (done.stdout + done.stderr).splitlines():  # pydoclint reports on stderr
        if line and not line[0].isspace():
            current = (ROOT / line.strip()).resolve()
            continue
        match = VIOLATION.match(line)
        if match and current is not None:
            violations.setdefault((current, match.group(2)), []).append(line.strip())
    return violations


def names(listed: str) -> set[str]:
    return {name.strip(" '\"") for name in listed.split(",") if name.strip()}


def counts(line: str) -> bool:
    """Whether a pydoclint violation is one this project holds the public API to.

    Raises must name every exception the function's own ``raise`` statements raise (DOC501, and DOC503 when one
    is missing), and may also name what the helpers it calls raise: the reader needs those too, and pydoclint,
    which reads one body at a time, would call them extra (DOC502, and DOC503 for the extra names only).
    """
    if "DOC502: " in line:
        return False
    mismatch = RAISES_MISMATCH.search(line) if "DOC503: " in line else None
    if mismatch:
        documented, raised = names(mismatch.group(1)), names(mismatch.group(2))
        return bool(raised - documented - RE_RAISED)
    return True


def test_the_public_api_holds_the_exported_classes_functions_and_their_methods():
    api = public_api()
    names = {name for definitions in api.values() for name in definitions}
    assert {"load_ifc", "BimModel", "BimModel.element", "write_bytes_atomic", "Bim2RdtError"} <= names
    assert sum(map(len, api.values())) > 300


def test_every_public_class_function_and_method_has_a_docstring():
    missing = [f"{path.relative_to(ROOT)}: {name}" for path, definitions in public_api().items()
               for name, node in definitions.items()
               if ast.get_docstring(node) is None and not name.endswith(".__init__")]
    assert not missing, "public names without a docstring:\n" + "\n".join(missing)


def test_pydoclint_finds_the_public_api_docstrings_consistent_with_the_code():
    api = public_api()
    violations = pydoclint_violations(list(api))
    public = [f"{path.relative_to(ROOT)}: {line}" for (path, name), lines in sorted(violations.items())
              if name in api.get(path, {}) for line in lines if counts(line)]
    assert not public, f"{len(public)} pydoclint violations in the public API:\n" + "\n".join(public)


def griffe_problems(text: str) -> list[str]:
    """What the reference's parser (griffe, Google style, as mkdocstrings reads it) finds wrong with a docstring's
    sections: an item it cannot split into name and description, and a Returns section it reads as several
    values (a continuation line not indented under the first). Types come from signatures, so griffe's "no type
    or annotation" (it sees no signature here) is not a problem."""
    import griffe

    problems: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if "No type or annotation" not in record.getMessage():
                problems.append(record.getMessage())

    handler = Collect(logging.WARNING)
    logger = logging.getLogger("griffe")
    logger.addHandler(handler)
    try:
        sections = griffe.Docstring(text).parse("google")
    finally:
        logger.removeHandler(handler)
    problems += [f"Returns reads as {len(section.value)} values" for section in sections
                 if section.kind.value == "returns" and len(section.value) > 1]
    return problems


def test_the_reference_reads_every_public_docstring_as_written():
    found = [f"{path.relative_to(ROOT)}: {name}: {problem}" for path, definitions in public_api().items()
             for name, node in definitions.items() if ast.get_docstring(node)
             for problem in griffe_problems(ast.get_docstring(node))]
    assert not found, "docstrings the reference misreads:\n" + "\n".join(found)


def test_griffe_finds_a_returns_continuation_that_is_not_indented():
    text = "Do.\n\nArgs:\n    a: A thing.\n\nReturns:\n    The first line\n    and its continuation.\n"
    assert griffe_problems(text) == ["Returns reads as 2 values"]
    assert griffe_problems(text.replace("    and its", "        and its")) == []


def test_pydoclint_reports_a_missing_args_entry_a_missing_raises_and_a_missing_returns(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text('def scale(points: list, factor: float) -> list:\n'
                       '    """Scale points.\n\n    Args:\n        points: Points in metres.\n    """\n'
                       '    if factor <= 0:\n        raise ValueError("factor must be positive")\n'
                       '    return [p * factor for p in points]\n')
    codes = {line.split(":")[1].strip() for lines in pydoclint_violations([planted]).values() for line in lines
             if counts(line)}
    assert {"DOC101", "DOC201", "DOC501", "DOC503"} <= codes


def test_raises_may_name_what_helpers_raise_but_must_name_what_the_body_raises():
    body_only = ("DOC503: Function `f` exceptions in the \"Raises\" section in the docstring do not match those in "
                 "the function body. Raised exceptions in the docstring: ['A']. Raised exceptions in the body: {}.")
    assert counts(body_only.format("['A', 'B']"))
    assert not counts(body_only.format("['BaseException']"))
    assert not counts(body_only.replace("['A']", "['A', 'C']").format("['A']"))
    assert not counts("DOC502: Function `f` has a \"Raises\" section in the docstring, but there are not \"raise\"")
