"""Dead letters: bus messages the monitor refused, counted per device, logged, and kept with the exposure store.

A message that fails validation (a malformed payload, a rate too low to weigh, a device id that is not its
topic's, a malformed status) is counted under the device of its topic and acknowledged: it is never
redelivered and never stops the monitor. The first few per device are logged with the reason, then one in
``LOG_EVERY``, so a device sending garbage cannot flood the log.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

log = logging.getLogger("bim2rdt.safety")

LOG_FIRST = 5
"""Refused messages logged in full per device before the log thins out."""
LOG_EVERY = 1000
"""After that, one refused message in this many is logged (with the running count)."""


@dataclass
class MalformedMessages:
    """A device's refused messages: how many, the last reason and when the last one arrived (our clock, s)."""

    count: int = 0
    last_reason: str = ""
    last_received: float | None = None


class DeadLetters:
    """Counts of refused messages per device; ``dirty`` says which changed since they were last saved."""

    def __init__(self, saved: dict[str, MalformedMessages] | None = None):
        self.by_device: dict[str, MalformedMessages] = dict(saved or {})
        self.dirty: set[str] = set()

    def record(self, device: str, reason: str, received: float) -> None:
        entry = self.by_device.setdefault(device, MalformedMessages())
        entry.count += 1
        entry.last_reason, entry.last_received = reason[:200], received
        self.dirty.add(device)
        if entry.count <= LOG_FIRST or entry.count % LOG_EVERY == 0:
            log.warning("refused a message from device %s (%d so far): %s", device, entry.count, reason)

    def take_dirty(self) -> list[tuple[str, int, str, float | None]]:
        """(device, count, last reason, last received) rows changed since the last call."""
        rows = [(d, self.by_device[d].count, self.by_device[d].last_reason, self.by_device[d].last_received)
                for d in sorted(self.dirty)]
        self.dirty.clear()
        return rows
