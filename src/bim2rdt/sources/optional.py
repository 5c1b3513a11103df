"""Optional readers' packages: imported when a reader needs them, with one line naming the extra when missing."""

from __future__ import annotations

import importlib
from types import ModuleType

from bim2rdt.sources.errors import SourceError

EXTRA = "sensors"
"""The pip extra that installs every optional reader (``pip install 'bim2rdt[sensors]'``)."""


def require(module: str, path, what: str, extra: str = EXTRA) -> ModuleType:
    """``module`` imported, or :class:`SourceError`: reading ``what`` needs it, and the ``extra`` that installs it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise SourceError(path, f"reading {what} needs the Python package '{module.split('.')[0]}': "
                                f"pip install 'bim2rdt[{extra}]'") from None
