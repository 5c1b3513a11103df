"""The localization's typed error, and why a fix was refused (so callers branch on a kind, not on words)."""

from __future__ import annotations

from enum import Enum

from bim2rdt.errors import Bim2RdtError


class Refusal(str, Enum):
    """Why a frame or cloud was not localized; the value is what summaries count."""

    BAD_INPUT = "bad input"
    NO_MAP = "no map to localize on"
    TOO_FEW_RETURNS = "too few returns in range"
    NO_PERMANENT_IN_VIEW = "sees no permanent element"
    REGISTRATION = "registration failed"
    BEYOND_BASIN = "moved beyond the basin"
    FEW_INLIERS = "too few points on the BIM after the fix"
    BEHIND_WALLS = "points behind walls after the fix"
    NO_NORMALS = "no inlier with a surface normal"


class LocalizationError(Bim2RdtError):
    """A frame that cannot be localized on the BIM (it sees no permanent element, the fix left the basin, the
    model has no permanent structure, bad input); the message says why in one line, ``kind`` (a
    :class:`Refusal`) says it for code. A filter that gets it keeps the odometry.

    Args:
        message: The one-line reason.
        kind: What kind of refusal it is.
    """

    def __init__(self, message: str, kind: Refusal = Refusal.BAD_INPUT) -> None:
        super().__init__(message)
        self.kind = kind
