"""A fast look at a STEP file's text before ifcopenshell parses it: which entity ids it declares, and where.

ifcopenshell 0.9 crashes the whole process (SIGSEGV) on some files that declare one id twice (``#42=`` on two
lines: the second instance is indexed by type and GlobalId but not by id, IfcOpenShell PR 8858), so duplicate
ids must be caught here, before parsing. The fast pass is one regex over the bytes (~8 ms for Office_A's 4 MB and
63k entities); only when it finds a repeat does the exact pass run, which skips strings and comments so a
``'#5='`` inside a name cannot be mistaken for a declaration.
"""

from __future__ import annotations

import mmap
import re

Text = bytes | mmap.mmap
"""The file's bytes, read or memory-mapped."""
_DECLARED = re.compile(rb"#0*(\d+)\s*=")
_EXACT = re.compile(rb"'(?:[^']|'')*'|/\*.*?\*/|#(\d+)\s*=", re.S)


def has_repeated_ids(data: Text) -> bool:
    """The fast pass: True when some ``#n=`` occurs twice (possibly inside a string; confirm with
    :func:`declared_ids`)."""
    ids = _DECLARED.findall(data)
    return len(set(ids)) != len(ids)


def declared_ids(data: Text) -> list[tuple[int, int]]:
    """(entity id, byte offset) of every declaration ``#n=`` outside strings and comments, in file order."""
    return [(int(match.group(1)), match.start()) for match in _EXACT.finditer(data) if match.group(1)]


def first_duplicate(declarations: list[tuple[int, int]]) -> tuple[int, int, int] | None:
    """(id, offset of its first declaration, offset of the second) of the first id declared twice, or None."""
    first_seen: dict[int, int] = {}
    for entity_id, offset in declarations:
        if entity_id in first_seen:
            return entity_id, first_seen[entity_id], offset
        first_seen[entity_id] = offset
    return None


def line_of(data: Text, offset: int) -> int:
    """1-based line number of a byte offset."""
    return bytes(memoryview(data)[:offset]).count(b"\n") + 1


def line_of_entity(data: Text, entity_id: int) -> int | None:
    """1-based line of the declaration ``#entity_id=``, or None (error paths only: an exact pass over the file)."""
    offset = next((offset for declared, offset in declared_ids(data) if declared == entity_id), None)
    return line_of(data, offset) if offset is not None else None
