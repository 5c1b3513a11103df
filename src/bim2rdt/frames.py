"""The world frame every package shares: z-up, metres (docs/concepts/frames-and-units.md).

``UP`` is the world's up axis; ``UP_BODY`` a body frame's own up (a family's model, built upright along +z). They are
the same vector in two frames, so the registration's upright prior and the perception's fits pull a body's up
(``R_world_body @ UP_BODY``) onto ``UP``. Every package takes them from here."""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 0.0, 1.0])
"""The world's up axis (z), a unit (3,) vector. Read it, never write into it."""
UP.flags.writeable = False

UP_BODY = UP
"""A body's (a family model's) up axis in body coordinates: +z, the same read-only (3,) vector as :data:`UP`; the
name says the frame."""
