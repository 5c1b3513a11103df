"""Opening an IFC-SPF file safely: every way a file can be bad becomes a one-line ``BimError``.

ifcopenshell parses leniently: it forgives a missing ``END-ISO-10303-21;`` trailer, reads on past an entity
that lost its closing ``);`` (swallowing every line after it), and crashes the process on a file that declares
one id twice. So, in order:

1. the bytes are checked (exists, not empty, STEP, complete) and scanned for duplicate ids (``step_scan``);
2. the file is parsed with its own logger (``parser_log``): an error there stops loading with the first
   reason and its line; lost entities are counted and the line where they start is named;
3. the parsed file must be a supported schema and hold an IfcProject.

What the parser could read past (references to missing entities, wrong attribute counts) comes back as
``IfcSource.messages`` for the model to report with the elements they affect.
"""

from __future__ import annotations

import hashlib
import mmap
import re
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell

from bim2rdt.bim.errors import BimError
from bim2rdt.bim.integrity import locate_malformed
from bim2rdt.bim.parser_log import ParserMessage, open_logged
from bim2rdt.bim.step_scan import Text, declared_ids, first_duplicate, has_repeated_ids, line_of

STEP_MAGIC = b"ISO-10303-21;"
STEP_TRAILER = b"END-ISO-10303-21;"
SUPPORTED_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3")


@dataclass
class IfcSource:
    """A parsed file, the sha256 of its bytes, and the parser's warnings (nothing fatal: that raised)."""

    ifc: ifcopenshell.file
    digest: str
    messages: list[ParserMessage]


def read_source(path: str | Path) -> IfcSource:
    """Check, scan and parse an IFC-SPF file (see the module docstring).

    Args:
        path: The IFC-SPF file.

    Returns:
        The parsed source.

    Raises:
        BimError: Anything fatal about the file.
    """
    path = Path(path)
    check_bytes(path)
    with open(path, "rb") as stream, mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as data:
        digest = hashlib.sha256(data).hexdigest()
        _refuse_duplicate_ids(path, data)
        ifc, messages, error = open_logged(str(path))
        if error is not None:
            raise BimError(f"{path.name}: {_open_reason(path, data, error, messages)}") from None
        if any(m.fatal for m in messages):
            raise BimError(f"{path.name}: {_fatal_reason(path, data, ifc, messages)}")
    _check_model(path, ifc)
    return IfcSource(ifc, digest, messages)


def open_ifc(path: str | Path) -> ifcopenshell.file:
    """Parse an IFC-SPF file after checking it exists, is not empty, is STEP, complete and unambiguous."""
    return read_source(path).ifc


def file_digest(path: str | Path) -> str:
    """sha256 of the file's bytes: the key of every on-disk cache derived from it."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def check_bytes(path: Path) -> None:
    """The checks that need no parse: the file exists, is a non-empty file, starts as STEP and ends complete."""
    if not path.exists():
        raise BimError(f"{path}: no such IFC file")
    if not path.is_file():
        raise BimError(f"{path}: not a file")
    size = path.stat().st_size
    if size == 0:
        raise BimError(f"{path.name}: the file is empty (0 bytes)")
    with open(path, "rb") as stream:
        head = stream.read(64).lstrip(b"\xef\xbb\xbf \t\r\n")
        stream.seek(max(0, size - 256))
        tail = stream.read().rstrip()
    if not head.startswith(STEP_MAGIC):
        raise BimError(f"{path.name}: not an IFC-SPF file (it does not start with ISO-10303-21;)")
    if not tail.endswith(STEP_TRAILER):
        raise BimError(f"{path.name}: truncated (no END-ISO-10303-21; trailer at the end of {size} bytes)")


def _refuse_duplicate_ids(path: Path, data: Text) -> None:
    """Two entities with one id: which one a reference means is undecidable, and ifcopenshell may crash."""
    if not has_repeated_ids(data):
        return
    duplicate = first_duplicate(declared_ids(data))
    if duplicate is not None:
        entity_id, first, second = duplicate
        raise BimError(f"{path.name}: entity id #{entity_id} is declared twice (lines {line_of(data, first)} "
                       f"and {line_of(data, second)}); ids must be unique")


def _check_model(path: Path, ifc: ifcopenshell.file) -> None:
    if ifc.schema not in SUPPORTED_SCHEMAS:
        raise BimError(f"{path.name}: unsupported IFC schema {ifc.schema_identifier}; "
                       f"supported: {', '.join(SUPPORTED_SCHEMAS)}")
    projects = len(ifc.by_type("IfcProject"))
    if projects != 1:
        raise BimError(f"{path.name}: {'no' if projects == 0 else projects} IfcProject "
                       "(every IFC model has one: it holds the units and the spatial tree)")


def _fatal_reason(path: Path, data: Text, ifc: ifcopenshell.file, messages: list[ParserMessage]) -> str:
    """An entity that swallowed the ones after it is named as such; otherwise the parser's first error with its
    line, or, for an error that names no place (a value of the wrong type), the first schema violation."""
    fatal = [m for m in messages if m.fatal]
    more = f" (and {len(fatal) - 1} more parser errors)" if len(fatal) > 1 else ""
    declared = declared_ids(data)
    parsed = set(ifc.entity_names())
    lost = [(entity_id, offset) for entity_id, offset in declared if entity_id not in parsed]
    overruns = {m.overrun for m in messages} - {None}
    culprit = next(((i, o) for i, o in declared if i in overruns), None)
    if lost and culprit is not None:
        return (f"#{culprit[0]} on line {line_of(data, culprit[1])} does not end where it should (a lost ');'?) and "
                f"swallows the {len(lost)} entities after it, from #{lost[0][0]} on line {line_of(data, lost[0][1])}")
    first = fatal[0]
    if first.offset is not None:
        return f"line {line_of(data, first.offset)}: {first.text}{more}"
    located = locate_malformed(path, ifc)
    return f"{located} (ifcopenshell: {first.text}){more}" if located else f"{first.text}{more}"


def _open_reason(path: Path, data: Text, error: Exception, messages: list[ParserMessage]) -> str:
    if isinstance(error, ifcopenshell.SchemaError):
        return f"unknown IFC schema ({error}); supported: {', '.join(SUPPORTED_SCHEMAS)}"
    errors = [m for m in messages if m.severity == "error"]
    if not errors:
        return f"cannot parse: {error}"
    last = errors[-1]
    if last.offset is not None and _is_inside_escape(data, last.offset):
        return f"invalid STEP string escape near byte {last.offset} ({last.text} at offset {last.offset})"
    where = f" at offset {last.offset} (line {line_of(data, last.offset)})" if last.offset is not None else ""
    return f"STEP syntax error: {last.text}{where}"


def _is_inside_escape(data: Text, offset: int) -> bool:
    """True when the parse error sits right after a STEP escape opener (\\X\\, \\X2\\, \\X4\\, \\S\\, \\P)."""
    window = bytes(data[max(0, offset - 12):offset + 1])
    return re.search(rb"\\(X2|X4|X|S|P[A-I]?)\\?[0-9A-Fa-f]*.?$", window) is not None
