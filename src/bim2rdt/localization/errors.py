"""The localization's typed error."""

from bim2rdt.errors import Bim2RdtError


class LocalizationError(Bim2RdtError):
    """A frame that cannot be localized on the BIM (it sees no permanent element, the fix left the basin, the
    model has no permanent structure, bad input); the message says why in one line. A filter that gets it keeps
    the odometry."""
