"""A settled monitor process: the objects it built before its first message are out of the collector's passes."""

from __future__ import annotations

import gc

from bim2rdt.safety.heap import settle


def test_settle_takes_what_exists_out_of_full_collections():
    built = [[object()] for _ in range(50_000)]  # long-lived state, as a monitor's imports and restored streams
    try:
        frozen = settle()
        made_after = [[object()] for _ in range(10)]
        walked = {id(o) for o in gc.get_objects()}  # what the collector's passes (all generations) walk
        assert frozen >= len(built)
        assert not any(id(o) in walked for o in built)
        assert all(id(o) in walked for o in made_after)
    finally:
        gc.unfreeze()
    assert all(id(o) in {id(p) for p in gc.get_objects()} for o in built[:10])  # unfrozen, walked again
