"""What ifcopenshell says while it parses a file, kept per file instead of left in its global log.

ifcopenshell 0.9 parses on through bad input and only logs what it skipped: an unknown entity name, an
attribute list that runs on to the end of the file, a reference to an id no line declares. Each parse gets its
own in-memory logger (``ifcopenshell.open(..., logger=...)``), and its messages are sorted here into the ones
that make the file unreadable and the ones the reader can report and read past.

Read past (warnings): a reference to a missing entity (the attribute reads as unset), and everything ifcopenshell
itself rates a warning (an entity with the wrong number of attributes). Everything else ifcopenshell rates an
error (an unknown entity, a bad enumeration literal, a syntax error) means the text is not what its author
wrote, and loading stops.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper as wrapper

_OFFSET = re.compile(r"\s*at offset (\d+)\s*$")
_DANGLING = re.compile(r"^Instance reference #(\d+) used by instance #(\d+) at attribute index (\d+) not found")
_COUNTS = re.compile(r"Expected (\d+) attribute values, found (\d+) for instance #(\d+)")
_SEVERITIES = {wrapper.logger.LOG_WARNING: "warning", wrapper.logger.LOG_ERROR: "error"}


@dataclass(frozen=True)
class ParserMessage:
    """One message of the parser: ``severity`` "error" or "warning", the ``text`` without its byte offset,
    and the ``offset`` into the file where ifcopenshell gave one."""

    severity: str
    text: str
    offset: int | None = None

    @property
    def dangling(self) -> tuple[int, int, int] | None:
        """(missing id, referring instance id, attribute index) when this is a reference to a missing entity."""
        match = _DANGLING.match(self.text)
        return (int(match.group(1)), int(match.group(2)), int(match.group(3))) if match else None

    @property
    def overrun(self) -> int | None:
        """The instance id when this says an entity has more attribute values than its class: its attribute list
        ran on past where it should have closed."""
        match = _COUNTS.search(self.text)
        return int(match.group(3)) if match and int(match.group(2)) > int(match.group(1)) else None

    @property
    def fatal(self) -> bool:
        """True when the file cannot be read as its author meant it (see the module docstring)."""
        return self.severity == "error" and self.dangling is None


def parsing_logger() -> wrapper.logger:
    """A fresh logger that keeps its messages in memory, for one ``ifcopenshell.open``."""
    logger = wrapper.logger()
    logger.output_format(wrapper.logger.FMT_INMEMORY)
    return logger


def parser_messages(logger: wrapper.logger) -> list[ParserMessage]:
    """The warnings and errors a logger holds, in the order ifcopenshell logged them."""
    messages = []
    for entry in logger.log_messages():
        severity = _SEVERITIES.get(entry.severity)
        if severity is None:
            continue
        text = " ".join(entry.message.split())
        match = _OFFSET.search(text)
        offset = int(match.group(1)) if match else None
        messages.append(ParserMessage(severity, _OFFSET.sub("", text) if match else text, offset))
    return messages


def open_logged(path: str) -> tuple[ifcopenshell.file | None, list[ParserMessage], Exception | None]:
    """Parse a file with its own logger: (file or None, messages, the exception ``ifcopenshell.open`` raised).

    The file keeps a raw pointer to its logger and logs into it later (``create_entity`` does), so the logger is
    stored on the file object: freed with it, never before it (a freed logger segfaults the next write)."""
    logger = parsing_logger()
    try:
        ifc = ifcopenshell.open(path, logger=logger)
    except (ifcopenshell.Error, OSError) as error:
        return None, parser_messages(logger), error
    ifc.parse_logger = logger
    return ifc, parser_messages(logger), None
