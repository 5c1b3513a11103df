"""The suite's test folders are not packages, so pytest imports every test module by its file name alone: two
test files with one name in two folders stop the whole collection ("import file mismatch")."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def duplicate_names(root: Path) -> list[str]:
    """The test module names that more than one file under ``root`` has."""
    names = Counter(path.name for path in root.rglob("test_*.py") if "__pycache__" not in path.parts)
    return sorted(name for name, count in names.items() if count > 1)


def test_no_two_test_files_share_a_name():
    assert not duplicate_names(TESTS), "rename one of each: " + ", ".join(duplicate_names(TESTS))


def test_a_shared_name_is_found(tmp_path):
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "test_same.py").write_text("")
    (tmp_path / "a" / "test_other.py").write_text("")
    assert duplicate_names(tmp_path) == ["test_same.py"]
