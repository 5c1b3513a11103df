"""The twin's settings section (``Settings.twin``, ``BIM2RDT_TWIN__*``): where its history is stored and the
deviation tolerances it judges by. The edge (CLI, demo) unpacks it: the twin itself never reads settings."""

from __future__ import annotations

import re
from pathlib import Path

from pydantic import BaseModel, Field, field_serializer, model_validator

from bim2rdt.twin.tolerance import Tolerance, TolerancePolicy


class TolerancePreset(BaseModel):
    """How far an element may sit from its BIM pose and still be "as planned"."""

    translation: float = Field(gt=0, description="Largest offset of the element's origin, metres.")
    rotation_deg: float = Field(gt=0, description="Largest tilt, and largest yaw about up (modulo the family's "
                                "symmetry), degrees.")


def _default_presets() -> dict[str, TolerancePreset]:
    return {"temporary": TolerancePreset(translation=0.05, rotation_deg=5.0),
            "structural": TolerancePreset(translation=0.01, rotation_deg=0.5)}


def _default_preset_classes() -> dict[str, str]:
    structural = ("IfcColumn", "IfcWall", "IfcWallStandardCase", "IfcBeam", "IfcSlab", "IfcMember", "IfcFooting")
    return {ifc_class: "structural" for ifc_class in structural} | {"IfcBuildingElementProxy": "temporary"}


class TwinConfig(BaseModel):
    """The digital twin: where its history is stored and the deviation tolerances it judges by. Temporary site
    objects are loose (5 cm / 5 degrees); columns and walls are tight (1 cm / 0.5 degrees, as deviation checks
    use)."""

    url: str | None = Field(None, description="SQLAlchemy URL of the twin's history: sqlite:///path/twin.db or "
                            "postgresql+psycopg://user:password@host/db; None means data_dir/twin.db (SQLite).")
    presets: dict[str, TolerancePreset] = Field(default_factory=_default_presets, description="Named tolerances: "
                                                "temporary site objects are loose, structure is tight.")
    classes: dict[str, str] = Field(default_factory=_default_preset_classes,
                                    description="IFC class -> preset name.")
    families: dict[str, str] = Field(default_factory=dict, description="Family -> preset name (wins over class).")
    default_preset: str = Field("temporary", description="Preset of an element no class or family entry names.")
    min_fitness: float = Field(0.5, ge=0.0, le=1.0, description="Below this fitness an observation is unverified.")

    @field_serializer("url")
    def _url_without_password(self, url: str | None) -> str | None:
        """A dump (a run's config.json) never holds the database password."""
        return None if url is None else re.sub(r"(://[^:/@\s]*:)[^\s]*@", r"\1***@", url)

    @model_validator(mode="after")
    def _presets_exist(self) -> TwinConfig:
        named = {self.default_preset, *self.classes.values(), *self.families.values()}
        unknown = sorted(named - set(self.presets))
        if unknown:
            raise ValueError(f"tolerance preset(s) {', '.join(unknown)} not in presets ({', '.join(self.presets)})")
        return self

    def resolved_url(self, data_dir: Path) -> str:
        """The event store's URL.

        Args:
            data_dir: The folder of persistent state (``Settings.data_dir``).

        Returns:
            ``url``, or SQLite at ``data_dir/twin.db`` when none is set.
        """
        return self.url or f"sqlite:///{Path(data_dir) / 'twin.db'}"

    def tolerance_policy(self) -> TolerancePolicy:
        """The presets, class and family mappings as the twin's policy.

        Returns:
            The policy that picks each element's preset.
        """
        return TolerancePolicy({name: Tolerance(name, p.translation, p.rotation_deg)
                                for name, p in self.presets.items()}, dict(self.classes), dict(self.families),
                               self.default_preset)
