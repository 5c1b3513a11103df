"""Atomic IFC writes: a reader (or a crash) sees either the old file or the complete new one, never half.

The file is serialised in memory, checked to end with the STEP trailer, and handed to the project's
``write_bytes_atomic`` (temp file in the target folder, fsync, rename over the target).
"""

from __future__ import annotations

from pathlib import Path

import ifcopenshell

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim.errors import BimError
from bim2rdt.bim.source import STEP_TRAILER


def atomic_write_ifc(ifc: ifcopenshell.file, path: Path, *, replace_special: bool = False) -> Path:
    """Write ``ifc`` to ``path`` atomically; returns the path. OS errors (full disk, read-only folder, a folder
    or a device at ``path``) raise ``atomic.WriteError`` with one line, and the previous file is kept."""
    path = Path(path)
    if not path.parent.is_dir():
        raise BimError(f"{path}: the folder {path.parent} does not exist")
    data = ifc.to_string().encode("utf-8")
    if not data.rstrip().endswith(STEP_TRAILER):
        raise BimError(f"{path.name}: ifcopenshell serialised an incomplete file; nothing was written")
    return write_bytes_atomic(path, data, replace_special=replace_special)
