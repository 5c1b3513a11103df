"""Typed errors of the safety domain: each message is one line that says what is wrong."""

from bim2rdt.errors import Bim2RdtError


class HavError(Bim2RdtError):
    """Bad input to the hand-arm vibration maths or monitor (signal, rate, duration, recording)."""


class AccessDenied(HavError):
    """A role that may not read the identity map asked for a real name behind a pseudonym."""


class StoreError(HavError):
    """The exposure store cannot be opened, read or written (a bad URL, an unreachable server, a full disk)."""


class AlreadyApplied(HavError):
    """A commit would apply a batch the store's ledger already holds (keyed on device, boot, seq): the monitor's
    memory is behind the store (another process applied it, or a redelivery raced a restore); nothing was written."""
