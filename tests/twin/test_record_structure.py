"""A permanent element's structure judgement in the twin: ``twin state`` shows a wall as planned, deviating or not
built, with the judge's figures in its history; the exports carry it; what the judge does not give is refused."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

from bim2rdt.twin import Deviation, DigitalTwin, ElementStatus, Tolerance, TwinError

WALL = "2Bau$NfuHQWgIBDszY$vLS"
SLAB = "1Ui2Gfw5jPsBggdkyMS75E"


def _wall(site_model):
    return next(el for el in site_model.elements if el.global_id == WALL)


def test_a_wall_judged_deviating_then_not_built_shows_in_state_history_and_exports(site_model, tmp_path):
    moved = _wall(site_model).placement.copy()
    moved[0, 3] += 0.04
    loa = Tolerance("structure LOA30", 0.015, 1.0)
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model) as twin:
        state = twin.record_structure(WALL, ElementStatus.DEVIATING, 100.0, pose=moved,
                                      deviation=Deviation(0.04, 0.1, 0.0), tolerance=loa, frames=(0, 3),
                                      camera=np.eye(4), reason="offset 40 mm", measured={"coverage": 0.9})
        assert state.status is ElementStatus.DEVIATING and state.deviation.translation == 0.04
        assert state.tolerance == loa and state.evidence.frames == (0, 3)
        twin.record_structure(SLAB, ElementStatus.AS_PLANNED, 100.0, pose=np.eye(4), tolerance=loa)
        twin.record_structure(WALL, ElementStatus.NOT_BUILT, 200.0, frames=(5,))
        states = twin.state()
        assert states[WALL].status is ElementStatus.NOT_BUILT and states[WALL].pose is None
        assert states[SLAB].status is ElementStatus.AS_PLANNED
        assert twin.state(at=150.0)[WALL].status is ElementStatus.DEVIATING  # the history replays it
        history = twin.history(WALL)
        assert history[0].kind == "structure" and history[0].data["structure"] == {"coverage": 0.9}
        assert not twin.events(kinds=["observation"])  # the objects' observations stay the mission's alone
        assert [e.data["to"] for e in history if e.kind == "status"] == ["deviating", "not built"]
        exported = json.loads(twin.export_json(tmp_path / "twin.json").read_text())
        assert exported["counts"]["not built"] == 1
        with zipfile.ZipFile(twin.export_bcf(tmp_path / "issues.bcf")) as bcf:
            markup = " ".join(bcf.read(n).decode() for n in bcf.namelist() if n.endswith("markup.bcf"))
        assert "Not built" in markup and WALL in markup


def test_a_status_the_judge_does_not_give_or_a_deviating_element_without_a_pose_is_refused(site_model, tmp_path):
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model) as twin:
        with pytest.raises(TwinError, match="as planned, deviating or not built"):
            twin.record_structure(WALL, ElementStatus.NEW, 1.0)
        with pytest.raises(TwinError, match="needs its measured pose"):
            twin.record_structure(WALL, ElementStatus.DEVIATING, 1.0)
        with pytest.raises(TwinError, match="no element with GlobalId"):
            twin.record_structure("nope", ElementStatus.AS_PLANNED, 1.0)
        assert twin.history(WALL) == []  # nothing half-written
