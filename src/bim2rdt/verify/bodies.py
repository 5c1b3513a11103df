"""Planned bodies' surface samples, sampled once per model and element: the plan check, the judge, the owner of each
point and the new clusters all need an element's body in every frame that sees it."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.perception import element_body_mesh
from bim2rdt.registration import sample_model

BODY_CACHE_SIZE = 64
"""Bodies kept by :func:`body_samples` (3,000 samples and normals each, ~0.15 MB)."""
_BODIES: OrderedDict[tuple, tuple[np.ndarray, np.ndarray]] = OrderedDict()


def body_samples(model: BimModel, global_id: str, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """An element's body surface samples and their normals (its own frame, read-only), sampled once per model,
    element, count and seed: every frame that sees an element checks it, judges it, gives its points an owner
    and clears its points from the new clusters, each sampling it afresh before (~3 ms each).

    Args:
        model: The BIM, loaded with geometry.
        global_id: The element.
        count: How many samples.
        seed: The sampling's seed.

    Returns:
        (samples (count, 3), normals (count, 3)), metres, as :func:`~bim2rdt.registration.sample_model` gives
            them with ``drop_resting_face=False``.
    """
    key = (id(model), model.digest, global_id, count, seed)
    if key in _BODIES:
        _BODIES.move_to_end(key)
        return _BODIES[key]
    samples, normals = sample_model(element_body_mesh(model, global_id), count, seed=seed, drop_resting_face=False)
    samples.flags.writeable = False
    normals.flags.writeable = False
    _BODIES[key] = (samples, normals)
    if len(_BODIES) > BODY_CACHE_SIZE:
        _BODIES.popitem(last=False)
    return samples, normals
