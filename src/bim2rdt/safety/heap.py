"""The monitor process's heap, settled once it is built, so the cyclic garbage collector's full passes stay short.

A monitor process holds many long-lived objects once its imports (numpy, scipy, SQLAlchemy, pydantic, nats-py)
and its restored state are in, and every full collection walks them all while no message is committed (decision
0028). :func:`settle` moves them to the collector's permanent generation: later full passes walk only what the
process made since.
"""

from __future__ import annotations

import gc


def settle() -> int:
    """Collect once, then freeze what survives (call it when the monitor is built, before the first message).

    Returns:
        How many objects the collector now leaves out of its passes.
    """
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()
