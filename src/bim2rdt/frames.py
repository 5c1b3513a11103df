"""The world frame every package shares: z-up, metres (docs/DESIGN.md, "Units and frames").

``UP`` is the world's up axis; a body frame's own up (a family's model, z-up too) is the same vector, so the
registration's upright prior and the perception's fits pull a body's up onto this one."""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 0.0, 1.0])
"""The world's up axis (z), a unit (3,) vector. Read it, never write into it."""
UP.flags.writeable = False
