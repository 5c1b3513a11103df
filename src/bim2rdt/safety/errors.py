"""Typed errors of the safety domain: each message is one line that says what is wrong."""

from bim2rdt.errors import Bim2RdtError


class HavError(Bim2RdtError):
    """Bad input to the hand-arm vibration maths or monitor (signal, rate, duration, recording)."""


class AccessDenied(HavError):
    """A role that may not read the identity map asked for a real name behind a pseudonym."""
