"""bim2rdt.twin: the twin's element status (and, as it is built, its state, history and exports)."""

from bim2rdt.twin.status import ElementStatus

__all__ = ["ElementStatus"]
