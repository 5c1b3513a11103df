"""Sessions and corrections: who wears which device on which tool, and how their mounting is corrected.

A device is bound to a worker (stored only as a pseudonym), a tool, a body position, a work zone and a hand by
a *session* (from the device's retained status message or :meth:`HavMonitor.start_session`). A device nobody
has claimed yet counts under its own pseudonym as an estimate. Mounting corrections are fitted per (subject,
position) and apply to every stream of that subject at that position, except at the ISO measuring position.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from bim2rdt.safety.mounting import MountingCorrection
from bim2rdt.safety.privacy import IdentityMap, pseudonym

ISO_POSITIONS = ("handle",)
"""Positions where ISO 5349-1 measures (at the hand-tool interface): no correction, not an estimate."""


@dataclass
class Session:
    """Who wears a device, on which tool, where on the body and in which work zone."""

    subject: str
    tool: str = "unknown"
    position: str = "handle"
    zone: str | None = None
    hand: str = ""
    """'left' or 'right' when known: with both hands exposed the day counts the greater one."""

    @property
    def estimate(self) -> bool:
        """True when the wearable is not at an ISO 5349 position: its figures are estimates."""
        return self.position not in ISO_POSITIONS


class SessionBook:
    """Pseudonymous sessions (the identity map records who is behind each) and the fitted corrections."""

    def __init__(self, site_secret: str, identity: IdentityMap, corrections: Iterable[MountingCorrection] = ()):
        self.secret, self.identity = site_secret, identity
        self._corrections = {(c.subject, c.position): c for c in corrections}

    def claim(self, worker: str, tool: str = "unknown", position: str = "handle", zone: str | None = None,
              hand: str = "") -> Session:
        """A session for ``worker`` (remembered in the identity map under its pseudonym)."""
        subject = pseudonym(worker, self.secret)
        self.identity.remember(subject, worker)
        return Session(subject, tool, position, zone, hand)

    def anonymous(self, device: str) -> Session:
        """A device nobody has claimed yet: its own pseudonym, unknown tool and position (an estimate)."""
        return Session(pseudonym(f"device:{device}", self.secret), position="unknown")

    def correction(self, session: Session) -> MountingCorrection | None:
        """The correction for the session's subject and position; None at the ISO position or without a fit."""
        if not self._corrections:  # the usual case, asked for every stream of every round
            return None
        return self._corrections.get((session.subject, session.position)) if session.estimate else None

    def add_correction(self, correction: MountingCorrection) -> None:
        self._corrections[(correction.subject, correction.position)] = correction
