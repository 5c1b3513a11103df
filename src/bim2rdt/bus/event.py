"""The event schema every part of bim2rdt publishes: a kind, a time, a subject and a small JSON body."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any


@dataclass(frozen=True)
class Event:
    """One thing that happened on site.

    ``time`` is when it happened on the source's clock (UTC epoch seconds); ``received`` is when bim2rdt saw it
    (its own clock), kept apart because device clocks drift. ``subject`` is who or what it is about (a worker
    pseudonym, an element GlobalId); ``source`` is what reported it (a device id).
    """

    kind: str
    time: float
    subject: str
    source: str = ""
    data: dict[str, Any] = field(default_factory=dict)
    received: float | None = None

    def to_json(self) -> bytes:
        """The event as a JSON payload (numpy values as plain numbers).

        Returns:
            UTF-8 JSON with sorted keys.
        """
        return json.dumps(asdict(self), sort_keys=True, default=_plain).encode()

    @classmethod
    def from_json(cls, payload: bytes | str) -> Event:
        """An event from its JSON payload (``to_json``'s output).

        Args:
            payload: The JSON object.

        Returns:
            The event.
        """
        return cls(**json.loads(payload))


def _plain(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)
