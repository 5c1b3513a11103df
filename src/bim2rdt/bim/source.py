"""Opening an IFC-SPF file safely: every way a file can be bad becomes a one-line ``BimError``.

ifcopenshell parses lazily and forgives a missing ``END-ISO-10303-21;`` trailer (it silently reads what is
there), so the checks that matter for a twin (empty, not STEP, truncated) are done here before parsing, and
parse failures are translated using ifcopenshell's own log line (which carries the byte offset).
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import ifcopenshell

from bim2rdt.bim.errors import BimError

STEP_MAGIC = b"ISO-10303-21;"
STEP_TRAILER = b"END-ISO-10303-21;"
SUPPORTED_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3")
_OFFSET = re.compile(r"at offset (\d+)")


def open_ifc(path: str | Path) -> ifcopenshell.file:
    """Parse an IFC-SPF file after checking it exists, is not empty, is STEP and is complete."""
    path = Path(path)
    _check_bytes(path)
    try:
        ifc = ifcopenshell.open(str(path))
    except ifcopenshell.SchemaError as error:
        raise BimError(f"{path.name}: unknown IFC schema ({error}); supported: {', '.join(SUPPORTED_SCHEMAS)}") from None
    except (ifcopenshell.Error, OSError) as error:
        raise BimError(f"{path.name}: {_parse_reason(path, error)}") from None
    if ifc.schema not in SUPPORTED_SCHEMAS:
        raise BimError(f"{path.name}: unsupported IFC schema {ifc.schema_identifier}; "
                       f"supported: {', '.join(SUPPORTED_SCHEMAS)}")
    return ifc


def file_digest(path: str | Path) -> str:
    """sha256 of the file's bytes: the key of every on-disk cache derived from it."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _check_bytes(path: Path) -> None:
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


def _parse_reason(path: Path, error: Exception) -> str:
    """ifcopenshell says 'check logs'; the log's last error line holds the reason and byte offset."""
    lines = [line for line in ifcopenshell.get_log().splitlines() if "[error]" in line]
    detail = lines[-1].split("] ", 2)[-1].strip() if lines else str(error)
    match = _OFFSET.search(detail)
    if match and _is_inside_escape(path, int(match.group(1))):
        return f"invalid STEP string escape near byte {match.group(1)} ({detail})"
    return f"STEP syntax error: {detail}" if lines else f"cannot parse: {error}"


def _is_inside_escape(path: Path, offset: int) -> bool:
    """True when the parse error sits right after a STEP escape opener (\\X\\, \\X2\\, \\X4\\, \\S\\, \\P)."""
    with open(path, "rb") as stream:
        stream.seek(max(0, offset - 12))
        window = stream.read(13)
    return re.search(rb"\\(X2|X4|X|S|P[A-I]?)\\?[0-9A-Fa-f]*.?$", window) is not None
