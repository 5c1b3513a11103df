"""The monitor process's heap, settled once it is built and again as its streams grow, so the cyclic garbage
collector's full passes stay short.

A monitor process holds many long-lived objects once its imports (numpy, scipy, numba, SQLAlchemy, pydantic,
nats-py) and its streams are in, and every full collection walks them all while no message is committed: 60-180
ms on the NATS path (decision 0028), 115-145 ms every four or five rounds of ``bench hav``'s 2000 streams (decision
0051). :func:`settle` moves them to the collector's permanent generation: later full passes walk only what the
process made since. :class:`HeapSettler` does it for a monitor once its fleet is large (``SETTLE_FROM_STREAMS``)
and each time it has doubled, so a fleet that comes online after the process started is settled too. :func:`young_passes_after`
holds the collector's young passes to the end of a round of ingest: the round's own temporaries (pieces, blocks,
rows) are gone by then, so the one pass walks only what survives.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


def settle() -> int:
    """Collect once, then freeze what survives (call it when the monitor is built, before the first message).

    Returns:
        How many objects the collector now leaves out of its passes.
    """
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()


SETTLE_FROM_STREAMS = 64
"""A monitor settles its heap first when it holds this many streams. A smaller fleet's objects are few beside the
imports' (which ``hav listen`` settles when it starts), and a process that builds many small monitors (a test
suite) would pay a full pass over everything for each, as each one's close gives the frozen objects back."""


class HeapSettler:
    """Settles the heap (:func:`settle`) when a monitor's streams reach ``first``, then twice as many as at the last
    settle: a fleet of N devices costs about log2(N / first) settles, each a full pass over what was made since
    the one before.

    The collector's permanent generation is the process's: a frozen object that later becomes part of unreachable
    garbage is not collected while it stays frozen, so :meth:`release` (when the monitor closes) gives every frozen
    object back to the collector.

    Args:
        enabled: False leaves the collector alone (an application that manages it itself).
        first: The streams at the first settle.
    """

    def __init__(self, enabled: bool = True, first: int = SETTLE_FROM_STREAMS):
        self.enabled, self.first = enabled, max(1, first)
        self.settled_at = 0
        """The monitor's streams at its last settle (0: not settled)."""

    def grown(self, streams: int) -> bool:
        """Settle if the monitor's streams have doubled since the last settle (the first time: at ``first``).

        Args:
            streams: How many streams the monitor holds now.

        Returns:
            Whether it settled.
        """
        if not self.enabled or streams < max(self.first, 2 * self.settled_at):
            return False
        settle()
        self.settled_at = streams
        return True

    @contextmanager
    def round(self) -> Iterator[None]:
        """:func:`young_passes_after` around one round of ingest, when enabled."""
        if not self.enabled:
            yield
            return
        with young_passes_after():
            yield

    def release(self) -> None:
        """Give the frozen objects back to the collector, if this settler froze any (the monitor is closing)."""
        if self.settled_at:
            gc.unfreeze()
            self.settled_at = 0


@contextmanager
def young_passes_after() -> Iterator[None]:
    """Hold the cyclic collector's passes until the block is done, then make the young pass it would have made
    (when the objects made since the last pass are over the threshold), inside the block's time.

    A round of ingest makes tens of thousands of short-lived containers (a 2000-stream round of ``bench hav``: about
    30 young passes, each walking the round's pieces and blocks still alive). Held, most of them are gone before
    the one pass at the end. The collector stays as it was where it was off already (an application's choice),
    and it is on again when the block raises.
    """
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        if gc.get_count()[0] > gc.get_threshold()[0]:
            gc.collect(0)
