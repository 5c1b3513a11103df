"""Atomic IFC writes: a reader (or a crash) sees either the old file or the complete new one, never half.

Write to a temp file in the target's folder, check it parses, fsync it, rename over the target (atomic on
POSIX within one file system), then fsync the folder so the rename itself survives a power cut.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import ifcopenshell

from bim2rdt.bim.errors import BimError
from bim2rdt.bim.source import open_ifc


def atomic_write_ifc(ifc: ifcopenshell.file, path: Path) -> Path:
    """Write ``ifc`` to ``path`` atomically; returns the path."""
    path = Path(path)
    if not path.parent.is_dir():
        raise BimError(f"{path}: the folder {path.parent} does not exist")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp.ifc")
    os.close(fd)
    try:
        ifc.write(tmp)
        open_ifc(tmp)
        with open(tmp, "rb+") as stream:
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    _fsync_folder(path.parent)
    return path


def _fsync_folder(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
