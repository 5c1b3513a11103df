"""Text in the twin's history: checked where it enters, mended where an old store is read.

A name the twin stores (a family, a robot, a detector, a reason, a GlobalId, a device) must be text every backend
and every export can hold the same way: valid Unicode (a lone surrogate such as ``"\\ud800"`` cannot be encoded as
UTF-8, so once stored it broke every JSON answer and both exports for good), no control characters (PostgreSQL
refuses NUL; a newline would split a one-line message), and at most its limit long, which is the column's
length where it has a column (SQLite would store any length that PostgreSQL refuses). A history written before
these checks may still hold a lone surrogate: ``mended`` turns each into U+FFFD as it is read.
"""

from __future__ import annotations

import re
import unicodedata
from typing import Any

from bim2rdt.twin.errors import TwinError

LIMITS = {"family": 255, "robot": 128, "source": 128, "detector": 64, "reason": 1000, "GlobalId": 64}
"""Characters at most, per kind of name (family: an IfcLabel's 255; robot and source: the ``source`` column,
String(128); GlobalId: the ``global_id`` column, String(64))."""
_SURROGATE = re.compile("[\ud800-\udfff]")


def checked_text(value: Any, what: str, *, may_be_empty: bool = False) -> str:
    """``value`` if it is text the store holds alike everywhere (see the module); TwinError naming ``what`` (a key of
    LIMITS) otherwise. The error never repeats the bad text itself."""
    limit = LIMITS[what]
    if not isinstance(value, str):
        raise TwinError(f"the {what} must be text, got {type(value).__name__}")
    if not value and not may_be_empty:
        raise TwinError(f"the {what} is empty")
    if len(value) > limit:
        raise TwinError(f"the {what} has {len(value)} characters: at most {limit}")
    if bad := _SURROGATE.search(value):
        raise TwinError(f"the {what} is not valid Unicode (a lone surrogate at character {bad.start()})")
    for position, char in enumerate(value):
        if unicodedata.category(char) == "Cc":
            raise TwinError(f"the {what} holds a control character (U+{ord(char):04X} at character {position})")
    return str(value)


def mended(value: Any) -> Any:
    """``value`` (text, or JSON-like lists and dicts of it) with every lone surrogate replaced by U+FFFD."""
    if isinstance(value, str):
        return _SURROGATE.sub("\ufffd", value)
    if isinstance(value, list):
        return [mended(item) for item in value]
    if isinstance(value, dict):
        return {mended(key): mended(item) for key, item in value.items()}
    return value


def may_need_mending(json_text: str) -> bool:
    """Whether JSON text (as ``json.dumps`` escapes it) may hold a surrogate: only then is ``mended`` worth a walk."""
    return "\\ud" in json_text or "\\uD" in json_text
