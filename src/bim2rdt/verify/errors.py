"""verify's typed error."""

from bim2rdt.errors import Bim2RdtError


class VerifyError(Bim2RdtError):
    """Input verify cannot work with (no frames, a prior outside the model, a model with nothing to localize
    on, a bad up vector); one line."""
