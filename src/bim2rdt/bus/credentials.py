"""Broker addresses and credentials: which password each user logs in with.

Dev provisioning derives a device's password from a secret (:func:`device_password`), so a simulator and a
broker agree without exchanging files; a real site provisions each device's password individually. The HAV
monitor logs in with its own password (``BIM2RDT_MQTT__PASSWORD``), derived the same way only when none is set.
"""

from __future__ import annotations

import hashlib
import hmac

from bim2rdt.errors import Bim2RdtError


class CredentialError(Bim2RdtError):
    """A broker address or credential that cannot be used."""


def device_password(secret: str, device: str) -> str:
    """Dev provisioning: a device's broker password as a keyed hash of its id."""
    return hmac.new(secret.encode(), f"device:{device}".encode(), hashlib.sha256).hexdigest()[:32]


def user_password(user: str, monitor_user: str, monitor_password: str | None, device_secret: str) -> str:
    """The password ``user`` logs in with: the monitor's own if it is the monitor and one is set, else the
    dev-provisioned one."""
    if user == monitor_user and monitor_password:
        return monitor_password
    return device_password(device_secret, user)


def parse_address(value: str) -> tuple[str, int]:
    """'HOST:PORT' as (host, port); CredentialError in one line otherwise."""
    host, _, port = value.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise CredentialError(f"--mqtt wants HOST:PORT, got {value!r}")
    return host, int(port)
