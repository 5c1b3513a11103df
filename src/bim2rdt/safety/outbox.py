"""Durable delivery of the monitor's events to a sink that may be slow or down (the twin): the transactional
outbox.

A durable sink has a name (its ``outbox`` attribute, e.g. ``"twin"``). Each monitor commit queues its events for
every durable sink in the same transaction as the exposure they come from (:meth:`ExposureStore.add_events`), so
an event is queued if and only if its exposure is committed. An :class:`OutboxDelivery` thread per sink hands the
queue to the sink in commit order, a group at a time, and removes a group only after the sink took it; a sink that
fails (the twin is write-locked, its server is down) is retried every ``retry_s`` until it takes the group. The
monitor never waits for it: its accounting goes on, and its lock is never held while a sink works.

On PostgreSQL several monitor processes share the queue: the one holding the sink's advisory lock delivers it, the
others stand by (:meth:`ExposureStore.outbox_lease`). None lost: a group leaves the queue only after the sink
returned. None doubled: every delivered event carries its
queue id (``data["outbox_id"]``); when a delivery's outcome is unknown (the sink raised, or the process died
between the sink's commit and the queue's), the sink's ``delivered(events)`` (if it has one) says which ids it
already holds, and those are removed without being sent again.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence
from dataclasses import replace

from bim2rdt.bus import Event
from bim2rdt.safety.store import ExposureStore

log = logging.getLogger("bim2rdt.safety")

GROUP = 500
"""Events handed to the sink in one call at most."""


def outbox_name(sink) -> str | None:
    """The durable name of ``sink`` (its ``outbox`` attribute), None for a sink that takes events as they come."""
    name = getattr(sink, "outbox", None)
    return name if isinstance(name, str) and name else None


class OutboxDelivery:
    """Delivers one durable sink's queue from ``store`` on a background thread (see the module docstring)."""

    def __init__(self, store: ExposureStore, name: str, sink, retry_s: float = 1.0):
        self.store, self.name, self.sink, self.retry_s = store, name, sink, retry_s
        self.delivered = 0
        """Events the sink took in this process."""
        self.failures = 0
        """Deliveries that failed and were retried."""
        self.last_error: str | None = None
        self._wake, self._stop = threading.Event(), threading.Event()
        self._uncertain = True  # at start: a previous process may have died between the sink's commit and ours
        self._thread = threading.Thread(target=self._run, name=f"hav-outbox-{name}", daemon=True)

    def start(self) -> OutboxDelivery:
        self._thread.start()
        return self

    def wake(self) -> None:
        """New events were committed: deliver now."""
        self._wake.set()

    def pending(self) -> int:
        return self.store.outbox_count(self.name)

    def drain(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for the queue to empty; True when it did."""
        done = threading.Event()
        deadline = threading.Timer(timeout_s, done.set)
        deadline.daemon = True
        deadline.start()
        try:
            while not done.is_set():
                if self.pending() == 0:
                    return True
                self.wake()
                done.wait(min(0.02, self.retry_s))
            return self.pending() == 0
        finally:
            deadline.cancel()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join()

    def deliver_once(self) -> int:
        """Hand the oldest group to the sink; returns how many events it took (0: nothing waits). Raises what
        the sink raised (the group stays queued)."""
        if not self.store.outbox_lease(self.name):  # another monitor process delivers this queue
            return 0
        queued = self.store.outbox(self.name, GROUP)
        if not queued:
            return 0
        if self._uncertain:
            held = _already_delivered(self.sink, [event for _, event in _stamped(queued)])
            if held:
                self.store.outbox_done([i for i, _ in queued if i in held])
                queued = [(i, e) for i, e in queued if i not in held]
            self._uncertain = False
            if not queued:
                return 0
        events = [event for _, event in _stamped(queued)]
        try:
            _emit(self.sink, events)
        except BaseException:
            self._uncertain = True
            raise
        self.store.outbox_done([i for i, _ in queued])
        self.delivered += len(events)
        return len(events)

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                while not self._stop.is_set() and self.deliver_once():
                    pass
            except Exception as error:  # the sink is down: retried, never a refused message
                self.failures += 1
                self.last_error = f"{type(error).__name__}: {error}"
                if self.failures <= 5 or self.failures % 100 == 0:
                    log.warning("the %s sink did not take %d queued events (%d failures so far; retrying every "
                                "%g s): %s", self.name, self.pending(), self.failures, self.retry_s, self.last_error)
                self._stop.wait(self.retry_s)
                continue
            self._wake.wait(self.retry_s)
            self._wake.clear()


def _stamped(queued: Sequence[tuple[int, Event]]) -> list[tuple[int, Event]]:
    """Each event with its queue id in ``data["outbox_id"]``: the sink keeps it, so a redelivery is recognised."""
    return [(i, replace(event, data={**event.data, "outbox_id": i})) for i, event in queued]


def _already_delivered(sink, events: list[Event]) -> set[int]:
    """The queue ids among ``events`` the sink already holds (empty when it cannot say)."""
    delivered = getattr(sink, "delivered", None)
    return set(delivered(events)) if delivered is not None else set()


def _emit(sink, events: list[Event]) -> None:
    many = getattr(sink, "emit_many", None)
    if many is not None:
        many(events)
        return
    for event in events:
        sink.emit(event)
