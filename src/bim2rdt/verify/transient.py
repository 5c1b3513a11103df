"""What moves is not an object: new-object clusters that are people, or that changed place between frames.

A site is not empty while it is scanned: workers walk through, a barrow is pushed past. Such a cluster is not an
object the BIM lacks and must not become a "new" object with a BCF topic. Two tests, both geometric
(docs/decisions/0042 gives the measured reasons no image people detector is used):

- **a person's shape**: a cluster standing on the slab (its bottom within ``max_bottom`` of it), as tall as a
  person (``person_height``) and no wider than one (``max_width``). The demo's worker is 1.8 m tall and 0.5 m
  wide; office1's tallest unmodelled clutter stands 1.1 m (the office chair);
- **motion**: another frame with a usable fix saw through where the cluster's points were, at least
  ``moved_fraction`` of them in sight (``min_in_sight`` at least): the thing was there, then it was not.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import replace

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.verify.new_objects import NewCluster
from bim2rdt.verify.rays import RangeLookup


class TransientConfig(BaseModel):
    """Knobs of the transient tests (metres, shares): ``Settings.verify.transient`` (``BIM2RDT_VERIFY__TRANSIENT__*``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    person_height: tuple[float, float] = Field((1.4, 2.1), description="A cluster whose top stands this high "
                                               "above the slab (min, max) may be a person, m.")
    max_width: float = Field(1.0, gt=0.0, description="... and no wider than this in plan, m.")
    max_bottom: float = Field(0.3, ge=0.0, description="... and whose bottom is this close to the slab, m.")
    moved_fraction: float = Field(0.5, gt=0.0, le=1.0, description="A cluster another frame saw through at this "
                                  "share of its points in sight moved.")
    min_in_sight: int = Field(20, ge=1, description="Fewer of its points in sight of another frame and that frame "
                              "says nothing about it.")
    margin: float = Field(0.1, gt=0.0, description="A return this much beyond a point saw through it, m.")


def person_shaped(cluster: NewCluster, config: TransientConfig = TransientConfig()) -> bool:
    """Whether ``cluster`` stands on the slab as tall and as narrow as a person."""
    low, high = config.person_height
    return (low <= cluster.height <= high and cluster.width <= config.max_width
            and cluster.low[2] - cluster.slab <= config.max_bottom)


def moved(cluster: NewCluster, lookups: Iterable[RangeLookup], config: TransientConfig = TransientConfig()) -> bool:
    """Whether any of ``lookups`` (other frames' returns, each from its fixed pose) saw through where the
    cluster's points were."""
    for lookup in lookups:
        seen = lookup.compare(cluster.sample, config.margin)
        in_sight = seen[np.isfinite(seen) & (seen >= 0)]
        if len(in_sight) >= config.min_in_sight and (in_sight > 0).mean() >= config.moved_fraction:
            return True
    return False


def transient_reason(cluster: NewCluster, lookups: Iterable[RangeLookup],
                     config: TransientConfig = TransientConfig()) -> str:
    """Why ``cluster`` is transient ("" when it may be an object): a person's shape, or seen gone in another
    frame."""
    if person_shaped(cluster, config):
        return (f"a person's shape: {cluster.height:.2f} m tall, {cluster.width:.2f} m wide, standing on the "
                "slab")
    if moved(cluster, lookups, config):
        return "moved: another frame saw through where it stood"
    return ""


RECENT_FRAMES = 8
"""A cluster is tested for motion against this many frames before and after it (their range lookups are kept)."""


def mark_transient(result, recent: deque, config: TransientConfig = TransientConfig()) -> None:
    """Mark the clusters of ``result`` (a frame's result: ``clusters``, ``lookup``) that are people, or that the
    ``recent`` frames saw through, and the recent frames' clusters this frame saw through; then keep this frame
    among the recent ones (the oldest gives up its lookup: the window holds the returns it needs)."""
    lookups = [earlier.lookup for earlier in recent]
    result.clusters = [replace(c, transient=transient_reason(c, lookups, config)) for c in result.clusters]
    if result.lookup is None:
        return
    for earlier in recent:
        earlier.clusters = [c if c.transient else replace(c, transient=transient_reason(c, [result.lookup], config))
                            for c in earlier.clusters]
    if len(recent) == recent.maxlen:
        recent[0].lookup = None
    recent.append(result)
