"""The ROS section of the settings (``Settings.ros``, env ``BIM2RDT_ROS__...``): how a bag's messages are synced."""

from __future__ import annotations

from pydantic import BaseModel, Field


class RosConfig(BaseModel):
    """``sync_tolerance``: seconds within which a bag's colour, depth and TF samples belong to one frame;
    ``clock_tolerance``: header stamps this far (s) from the bag's receive times mean two clocks (reported)."""

    sync_tolerance: float = Field(0.02, gt=0, le=1.0)
    clock_tolerance: float = Field(1.0, gt=0)
