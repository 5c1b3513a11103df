"""What a reader may allocate: a header's counts are a claim, checked against the file's size and a memory cap
before any array is made (decision 0036).

- :func:`check_claim`: the bytes a header says follow (points x record length, VLRs, image sides) must be in the
  file. A 267-byte LAS declaring 3e8 points, or an ASCII PCD declaring 100000 x 100000, is refused in one line.
- :func:`check_memory`: what reading would allocate must fit the memory cap: by default
  :data:`DEFAULT_MEMORY_FRACTION` of the machine's RAM, set at the edge from ``Settings.sources``
  (``BIM2RDT_SOURCES__MAX_MEMORY_FRACTION`` or ``..._MAX_MEMORY_BYTES``) with :func:`memory_cap`. Compressed
  data (LAZ, E57, a binary_compressed PCD) cannot be bounded by its file size: the cap is what stops it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

from pydantic import BaseModel, Field

from bim2rdt.sources.errors import SourceError

DEFAULT_MEMORY_FRACTION = 0.5
"""The share of the machine's RAM one recording may take to read: half leaves the rest to the BIM, the
localization and the operating system."""
MAX_IMAGE_SIDE = 32768
"""The largest image side (pixels) a header may declare: 8K video is 7680 wide."""

_cap: ContextVar[int | None] = ContextVar("bim2rdt_memory_cap", default=None)


class SourcesConfig(BaseModel):
    """The readers' section of the settings (``Settings.sources``, env ``BIM2RDT_SOURCES__...``)."""

    max_memory_fraction: float = Field(DEFAULT_MEMORY_FRACTION, gt=0.0, le=1.0, description="A recording whose "
                                       "reading would take more than this share of the machine's RAM is refused "
                                       "in one line.")
    max_memory_bytes: int | None = Field(None, gt=0, description="The same cap in bytes; when set it replaces "
                                         "the fraction.")

    def memory_cap_bytes(self) -> int:
        """The cap in bytes: ``max_memory_bytes``, else the fraction of :func:`total_memory`.

        Returns:
            Bytes a reader may allocate for one recording.
        """
        return self.max_memory_bytes or int(self.max_memory_fraction * total_memory())


def total_memory() -> int:
    """The machine's physical memory, bytes (sysconf; 8 GiB where the system does not say).

    Returns:
        Bytes of RAM.
    """
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8 * 2**30


def current_cap() -> int:
    """The cap in force: the one :func:`memory_cap` set, else :data:`DEFAULT_MEMORY_FRACTION` of the RAM.

    Returns:
        Bytes a reader may allocate for one recording.
    """
    cap = _cap.get()
    return cap if cap is not None else int(DEFAULT_MEMORY_FRACTION * total_memory())


@contextmanager
def memory_cap(limit_bytes: int) -> Iterator[None]:
    """Readers inside the block refuse what would take more than ``limit_bytes`` (the edge sets it from
    ``Settings.sources.memory_cap_bytes()``).

    Args:
        limit_bytes: The cap, bytes.

    Yields:
        Nothing; the cap holds until the block ends.
    """
    token = _cap.set(int(limit_bytes))
    try:
        yield
    finally:
        _cap.reset(token)


def limit_memory(limit_bytes: int) -> None:
    """Set the cap for the rest of this context: what a command does once, at the edge, from
    ``Settings.sources.memory_cap_bytes()`` (library code uses :func:`memory_cap`'s block instead).

    Args:
        limit_bytes: The cap, bytes.
    """
    _cap.set(int(limit_bytes))


def check_memory(path: str | Path, need_bytes: float, what: str) -> None:
    """Refuse a read that would allocate more than the cap.

    Args:
        path: The file, named in the error.
        need_bytes: What reading it would allocate, bytes (an estimate from the header's counts).
        what: What the header declares, in a few words ("3e+08 points").

    Raises:
        SourceError: ``need_bytes`` is over the cap; one line with both sizes and the setting that raises it.
    """
    cap = current_cap()
    if need_bytes > cap:
        raise SourceError(path, f"its header declares {what}: reading it needs {_size(need_bytes)}, over the memory "
                                f"cap of {_size(cap)} (BIM2RDT_SOURCES__MAX_MEMORY_FRACTION, "
                                f"default {DEFAULT_MEMORY_FRACTION:g} of the RAM)")


def check_claim(path: str | Path, claimed_bytes: float, what: str, file_bytes: int | None = None) -> None:
    """Refuse a header that declares more data than the file holds.

    Args:
        path: The file, named in the error.
        claimed_bytes: The bytes the header says the file holds (header included).
        what: What the header declares, in a few words.
        file_bytes: The file's size; None reads it.

    Raises:
        SourceError: The file is smaller than the claim: truncated, or a damaged or hostile header.
    """
    size = Path(path).stat().st_size if file_bytes is None else file_bytes
    if claimed_bytes > size:
        raise SourceError(path, f"its header declares {what} ({_size(claimed_bytes)}) but the file holds "
                                f"{_size(size)}: truncated or damaged")


def check_image_side(path: str | Path, width: int, height: int, what: str) -> None:
    """Refuse an image size no sensor makes (each side 1 to :data:`MAX_IMAGE_SIDE` pixels).

    Args:
        path: The file, named in the error.
        width: Declared width, pixels.
        height: Declared height, pixels.
        what: Whose size it is ("the DEPTH track").

    Raises:
        SourceError: A side is under 1 or over :data:`MAX_IMAGE_SIDE`.
    """
    if not (0 < width <= MAX_IMAGE_SIDE and 0 < height <= MAX_IMAGE_SIDE):
        raise SourceError(path, f"{what} declares {width}x{height} pixels (each side is 1 to {MAX_IMAGE_SIDE})")


def _size(count: float) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if count >= scale:
            return f"{count / scale:.3g} {unit}"
    return f"{int(count)} bytes"
