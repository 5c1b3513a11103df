"""The project's typed errors. The CLI turns any of these into a one-line message and a non-zero exit."""


class Bim2RdtError(Exception):
    """Base of every error bim2rdt raises on bad input; its message is one line that says what is wrong."""
