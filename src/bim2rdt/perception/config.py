"""The perception front end's settings as one section of ``Settings`` (``BIM2RDT_PERCEPTION__*``)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.perception.geometric import GeometricConfig
from bim2rdt.perception.perceive import PerceiveConfig


class PerceptionConfig(BaseModel):
    """The perception front end's settings (``Settings.perception``, ``BIM2RDT_PERCEPTION__*``): the geometric
    detector's stages and what follows the detector."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    geometric: GeometricConfig = Field(default_factory=GeometricConfig)
    """The geometric detector (:class:`~bim2rdt.perception.GeometricDetector`)."""
    perceive: PerceiveConfig = Field(default_factory=PerceiveConfig)
    """Locating, fusing and fitting what a detector found."""
