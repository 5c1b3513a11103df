"""Timing hooks around verify's stages, for ``bim2rdt bench verify``: a listener set for the duration of a
``with listening(callback):`` block hears ``callback(stage, wall_seconds, cpu_seconds)`` for each stage of each frame. Without a
listener a stage costs one context-variable look-up."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

Listener = Callable[[str, float, float], None]
"""Called with a stage's name, its wall seconds and its process CPU seconds."""

_LISTENER: ContextVar[Listener | None] = ContextVar("verify_stage_listener", default=None)


@contextmanager
def stage(name: str) -> Iterator[None]:
    """Time the block as stage ``name`` for the current listener, if any.

    Args:
        name: The stage: "setup", "localize", "depth check" or "objects".

    Yields:
        Nothing; the block runs as it is.
    """
    listener = _LISTENER.get()
    if listener is None:
        yield
        return
    start, cpu = time.perf_counter(), time.process_time()
    try:
        yield
    finally:
        listener(name, time.perf_counter() - start, time.process_time() - cpu)


@contextmanager
def listening(listener: Listener) -> Iterator[None]:
    """Send the stages run inside the block to ``listener``.

    Args:
        listener: Called with each stage's name, wall seconds and process CPU seconds.

    Yields:
        Nothing.
    """
    token = _LISTENER.set(listener)
    try:
        yield
    finally:
        _LISTENER.reset(token)
