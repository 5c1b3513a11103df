"""The registration's typed error."""

from bim2rdt.errors import Bim2RdtError


class RegistrationError(Bim2RdtError):
    """Bad input to :func:`bim2rdt.registration.register` (shapes, non-finite values, non-rigid pose, too few
    points); the message says which argument and why."""
