"""bim2rdt.twin: the site's digital twin: element status against the BIM, an append-only history (SQLite or
PostgreSQL through SQLAlchemy Core), and exports to IFC, JSON and BCF.

```python
from bim2rdt.twin import DigitalTwin, ElementStatus
twin = DigitalTwin.open("sqlite:///out/twin.db", model)
twin.record(observation, time); twin.state(at=None); twin.history(global_id)
twin.export_ifc(path); twin.export_bcf(path)
write_progress(twin, out_dir)        # progress against the model's work schedule: progress.json and more
```
"""

from bim2rdt.twin.deviation import Deviation, pose_deviation
from bim2rdt.twin.errors import TwinError
from bim2rdt.twin.judge import FitEvidence, JudgeConfig, Judgement, PlaceEvidence, judge_evidence, place_seen_empty
from bim2rdt.twin.records import (EVENT_KINDS, MISSING, OBSERVATION, SAFETY, STATUS, STRUCTURE, ElementState,
                                  Evidence, Fit, TwinEvent)
from bim2rdt.twin.sink import TwinSink, recorded_outbox_ids
from bim2rdt.twin.status import STATUS_COLOURS, ElementStatus
from bim2rdt.twin.config import TolerancePreset, TwinConfig
from bim2rdt.twin.tolerance import Tolerance, TolerancePolicy
from bim2rdt.twin.verdict import against_tolerance, fit_trusted
from bim2rdt.twin.progress import ScheduleProgress, TaskProgress, TaskStatus, schedule_progress
from bim2rdt.twin.progress_config import ProgressConfig
from bim2rdt.twin.progress_files import (ProgressFiles, open_model_ifc, progress_of, progress_record, progress_section,
                                         read_structure_statuses, write_progress)
from bim2rdt.twin.progress_report import progress_markdown

__all__ = ["against_tolerance", "Deviation", "DigitalTwin", "ElementState", "ElementStatus", "EVENT_KINDS", "Evidence",
           "Fit", "fit_trusted", "FitEvidence", "ISSUES", "judge_evidence", "JudgeConfig", "Judgement", "MISSING",
           "OBSERVATION", "open_model_ifc", "place_seen_empty", "PlaceEvidence", "pose_deviation", "progress_markdown",
           "progress_of", "progress_record", "progress_section", "ProgressConfig", "ProgressFiles",
           "read_structure_statuses", "recorded_outbox_ids", "SAFETY", "schedule_progress", "ScheduleProgress",
           "STATUS", "STATUS_COLOURS", "STRUCTURE", "TaskProgress", "TaskStatus", "Tolerance", "TolerancePolicy",
           "TolerancePreset", "topic_title", "TopicView", "TwinConfig", "TwinError", "TwinEvent", "TwinSink",
           "vertical_fov_deg", "write_bcf", "write_progress"]

_HOMES = {"DigitalTwin": "twin", "ISSUES": "bcf_export", "TopicView": "bcf_export", "topic_title": "bcf_export",
          "write_bcf": "bcf_export", "vertical_fov_deg": "snapshot"}
"""Names imported on first use: the store (SQLAlchemy), the BIM reader, BCF and rendering are heavy."""


def __getattr__(name: str):
    if name in _HOMES:
        import importlib

        return getattr(importlib.import_module(f"bim2rdt.twin.{_HOMES[name]}"), name)
    raise AttributeError(name)
