"""bim2rdt.structure: is each permanent element (wall, slab, column, beam, stair, door, window) built, where it is,
and within its tolerance; and each return's signed distance to the nearest permanent face (deviation maps).

```python
from bim2rdt.structure import StructureView, judge_structure
judgements = judge_structure(model, [StructureView(0, points_sensor, T_world_sensor)])
```
"""

from bim2rdt.structure.config import StructureConfig, StructureTolerance
from bim2rdt.structure.errors import StructureError
from bim2rdt.structure.judge import judge_structure, judgements
from bim2rdt.structure.records import (STRUCTURE_STATUSES, StructureJudgement, StructureView, read_structure_json,
                                       write_structure_json)
from bim2rdt.structure.scene import PERMANENT_CLASSES
from bim2rdt.structure.maps import DeviationMaps
from bim2rdt.structure.survey import StructureSurvey, tolerance_of

__all__ = ["DeviationMaps", "PERMANENT_CLASSES", "STRUCTURE_STATUSES", "StructureConfig", "StructureError", "StructureJudgement",
           "StructureSurvey", "StructureTolerance", "StructureView", "judge_structure", "judgements", "read_structure_json",
           "tolerance_of", "write_structure_json"]
