"""Docstrings and pydantic ``Field(description=...)`` texts say what the code does and why, never what it used to
do or which issue asked for it: history belongs in git and docs/decisions/."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import bim2rdt

SOURCE = Path(bim2rdt.__file__).parent
HISTORY = re.compile(r"\bissues? \d+|\b(?:it|they|this|that|which|we|he|she)\s+used to\b|\bused to be\b|\bno longer\b|"
                     r"\bpreviously\b|\bbefore this\b", re.IGNORECASE)
"""Words that tell history. "the rank used to pick" is plain English and passes; "it used to" does not."""


def documentation_strings(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, text) of every docstring (a bare string statement: module, class, function and attribute
    docstrings) and every ``Field(..., description=...)``'s text in a parsed module."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            found.append((node.lineno, node.value.value))
        elif isinstance(node, ast.Call) and _called_name(node.func) == "Field":
            for keyword in node.keywords:
                if keyword.arg == "description":
                    text = " ".join(part.value for part in ast.walk(keyword.value)
                                    if isinstance(part, ast.Constant) and isinstance(part.value, str))
                    found.append((keyword.value.lineno, text))
    return found


def _called_name(func: ast.expr) -> str | None:
    return func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else None


def history_in(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [f"{path.relative_to(SOURCE.parent)}:{line}: {match.group(0)!r}"
            for line, text in documentation_strings(tree) for match in [HISTORY.search(" ".join(text.split()))]
            if match]


def test_the_scanner_finds_history_in_a_docstring_and_in_a_field_description(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text('"""It used to read the whole file."""\nfrom pydantic import Field\n'
                       'x: int = Field(1, description="Added for issue " "13.")\n'
                       'def f():\n    """The rank used to pick the best match."""\n')
    found = history_in_text(planted)
    assert [line for line, _ in found] == [1, 3]


def history_in_text(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [(line, text) for line, text in documentation_strings(tree) if HISTORY.search(" ".join(text.split()))]


def test_no_docstring_or_field_description_under_src_tells_history():
    found = [hit for path in sorted(SOURCE.rglob("*.py")) for hit in history_in(path)]
    assert not found, "history in docstrings or Field descriptions:\n" + "\n".join(found)
