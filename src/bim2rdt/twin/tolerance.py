"""Deviation tolerances per IFC class or family, from named presets.

Temporary site objects (a cone, a pallet) are loose: 5 cm and 5 degrees. Columns and walls are tight: 1 cm and
0.5 degrees, the order of the plumb and line tolerances construction deviation checks use. A family entry wins
over a class entry, so one family of proxies can be made tight without touching the rest.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from bim2rdt.twin.errors import TwinError


@dataclass(frozen=True)
class Tolerance:
    """A preset: its ``name``, the largest ``translation`` (m) and the largest tilt or yaw (``rotation_deg``)."""

    name: str
    translation: float
    rotation_deg: float

    def to_dict(self) -> dict:
        """The fields as JSON-ready data.

        Returns:
            {field: value}: name, translation (metres) and rotation_deg (degrees).
        """
        return {"name": self.name, "translation": self.translation, "rotation_deg": self.rotation_deg}


@dataclass(frozen=True)
class TolerancePolicy:
    """Which preset applies to an element: by family, else by IFC class, else ``default``."""

    presets: Mapping[str, Tolerance]
    classes: Mapping[str, str] = field(default_factory=dict)
    families: Mapping[str, str] = field(default_factory=dict)
    default: str = "temporary"

    def __post_init__(self) -> None:
        named = {self.default, *self.classes.values(), *self.families.values()}
        if unknown := sorted(named - set(self.presets)):
            raise TwinError(f"tolerance preset(s) {', '.join(unknown)} not defined ({', '.join(self.presets)})")

    def for_element(self, ifc_class: str | None, family: str | None) -> Tolerance:
        """The preset that applies to an element: by family, else by IFC class, else the default.

        Args:
            ifc_class: The element's IFC class (None for an object the BIM lacks).
            family: The element's family, if any.

        Returns:
            The tolerance preset.
        """
        name = self.families.get(family or "") or self.classes.get(ifc_class or "") or self.default
        return self.presets[name]
