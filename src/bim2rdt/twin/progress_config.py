"""The progress settings section (``Settings.progress``, ``BIM2RDT_PROGRESS__*``): when a task of the schedule
counts as behind or ahead. The edge unpacks it; the progress computation takes plain numbers."""

from __future__ import annotations

from pydantic import BaseModel, Field


class ProgressConfig(BaseModel):
    """Progress against the 4-D schedule. A task is behind when its observed percentage is under its planned one
    by more than ``behind_percent`` percentage points, ahead when over by more than ``ahead_percent``. Ten points
    is one day of a ten-day task: the resolution a weekly site walk reports at (decision 0033)."""

    behind_percent: float = Field(10.0, ge=0, le=100, description="Percentage points observed under planned "
                                  "beyond which a task is behind.")
    ahead_percent: float = Field(10.0, ge=0, le=100, description="Percentage points observed over planned beyond "
                                 "which a task is ahead.")
