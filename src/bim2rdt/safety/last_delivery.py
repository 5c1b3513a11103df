"""A bus message on its last delivery: applied alone, or dead-lettered with the reason it could not be.

A message a broker has delivered ``max_deliver`` times (on the NATS path: its commit failed each time, and the
monitor process restarted or the acknowledgement timed out) is given one last try on its own. If that fails
too, it is not left to vanish: the monitor's memory goes back to what its store holds (the failed commit is
undone), the message is dead-lettered under its device (:mod:`~bim2rdt.safety.deadletters`, kind
``undeliverable``, the reason saying how often and why) and that is committed. The bus then terminates it.
A store that cannot take even the dead letter is a failure of the monitor (``HavMonitor.failure``): the message
stays unacknowledged, for the next start.
"""

from __future__ import annotations

import logging

from bim2rdt.bus import decode_summary
from bim2rdt.bus import PayloadError
from bim2rdt.bus import device_of

log = logging.getLogger("bim2rdt.safety")
UNDELIVERABLE = "undeliverable"
"""The dead-letter kind (``stats`` key) of a message that could not be committed on its last delivery."""


def apply_last_delivery(monitor, topic: str, payload: bytes, deliveries: int) -> bool:
    """Apply ``payload`` (an accel, summary or status message of ``topic``) alone; if that raises, dead-letter it
    and return True. Raises (after ``monitor.fail``) only when the dead letter cannot be committed either."""
    try:
        _apply(monitor, topic, payload)
        return False
    except Exception as error:
        reason = (f"not committed after {deliveries} deliveries: {type(error).__name__}: {error}")
    device = device_of(topic) or "?"
    try:
        monitor.save_dead_letters()
        monitor.refresh()  # memory back to the store: whatever the failed call had changed is undone
        monitor.refuse(device, reason, monitor.clock(), kind=UNDELIVERABLE)
        monitor.save_dead_letters()
    except Exception as error:
        monitor.fail(f"the exposure store failed: {error}")
        raise
    log.error("dead-lettered a message of device %s on its last delivery: %s", device, reason)
    return True


def _apply(monitor, topic: str, payload: bytes) -> None:
    leaf = topic.rsplit("/", 1)[-1]
    if leaf == "status":
        monitor.on_status(topic, payload)
    elif leaf == "summary":
        _apply_summary(monitor, topic, payload)
    else:
        monitor.ingest_payload(topic, payload)


def _apply_summary(monitor, topic: str, payload: bytes) -> None:
    device, now = device_of(topic) or "?", monitor.clock()
    try:
        summary = decode_summary(payload)
    except PayloadError as error:
        monitor.refuse(device, str(error), now)
        return
    if summary.device != device:
        monitor.refuse(device, f"summary device id {summary.device!r} is not the topic's", now, kind="mismatched")
        return
    monitor.ingest_many([summary.received_at(now)], now=now)
