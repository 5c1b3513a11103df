"""A twin store a run did not finish says so when it is read (issue 36, item 12): verify's rebuild of twin.db is a
run of the store, marked started with its tables and finished after its last record; readers refuse a store whose
run never finished (``twin state`` exits 1 in one line) unless asked for the partial state, which is marked."""

from __future__ import annotations

import json
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from bim2rdt.perception.observation import Observation
from bim2rdt.twin import DigitalTwin, TwinError

from twin_helpers import T0


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "bim2rdt", "twin", *map(str, args)], capture_output=True,
                          text=True, timeout=300)


def _cones(model):
    return [el for el in model.elements if el.family == "Traffic_Cone_Orange_70cm"]


def test_a_store_whose_run_did_not_finish_is_refused_by_readers_and_marked_when_asked(twin_url, site_model):
    url = twin_url  # SQLite and PostgreSQL
    cone = _cones(site_model)[0]
    twin = DigitalTwin.open(url, site_model, run="verify")
    twin.record(Observation(cone.family, cone.global_id, cone.placement, 0.004, 0.9, 200), T0)
    twin.close()  # as a kill leaves it: no finish_run
    with pytest.raises(TwinError, match="is partial: the verify run that began building it at .* did not finish"):
        DigitalTwin.open(url, site_model, create=False)
    with DigitalTwin.open(url, site_model, create=False, partial=True) as reader:
        assert [source for source, _ in reader.unfinished_runs()] == ["verify"]
        assert reader.state()[cone.global_id].status.value == "as planned"


def test_a_finished_run_and_a_store_without_runs_read_as_whole(tmp_path, site_model):
    cone = _cones(site_model)[0]
    for name, run in (("finished.db", "verify"), ("live.db", None)):
        url = f"sqlite:///{tmp_path / name}"
        with DigitalTwin.open(url, site_model, run=run) as twin:
            twin.record(Observation(cone.family, cone.global_id, cone.placement, 0.004, 0.9, 200), T0)
            if run:
                twin.finish_run()
        with DigitalTwin.open(url, site_model, create=False) as reader:
            assert reader.unfinished_runs() == [] and cone.global_id in reader.state()


def _result(model, frames: int):
    """A VerifyResult-shaped record: ``frames`` frames, each seeing every cone as planned."""
    from bim2rdt.twin import ElementStatus

    cones = _cones(model)
    seen = [Observation(c.family, c.global_id, c.placement, 0.004, 0.9, 200) for c in cones]
    return SimpleNamespace(frames=[SimpleNamespace(index=i, time=T0 + i, pose=np.eye(4), missing=[], observations=seen)
                                   for i in range(frames)],
                           elements=[SimpleNamespace(global_id=o.global_id, status=ElementStatus.AS_PLANNED,
                                                     frames=list(range(frames)), observation=o) for o in seen],
                           new=[])


def test_a_verify_rebuild_cut_short_leaves_a_twin_that_twin_state_refuses(tmp_path, site_ifc, site_model,
                                                                          monkeypatch):
    """record_twin killed after 4 of its records (main listed them, exit 0, as if complete); a whole rebuild
    reads; ``--partial`` shows the 4 with a PARTIAL warning."""
    from bim2rdt.verify import record_twin

    calls = []
    real = DigitalTwin.record

    def killed_after_four(self, *args, **kwargs):
        if len(calls) == 4:
            raise KeyboardInterrupt  # the kill
        calls.append(1)
        return real(self, *args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(DigitalTwin, "record", killed_after_four)
        with pytest.raises(KeyboardInterrupt):
            record_twin(_result(site_model, 10), site_model, tmp_path, symmetry={})
    refused = _cli("state", site_ifc, "--url", tmp_path / "twin.db")
    assert refused.returncode == 1 and "partial" in refused.stderr and len(refused.stderr.splitlines()) == 1, \
        refused.stderr
    shown = _cli("state", site_ifc, "--url", tmp_path / "twin.db", "--partial", "--json")
    assert shown.returncode == 0 and "PARTIAL" in shown.stderr
    assert len(json.loads(shown.stdout)) >= 1
    record_twin(_result(site_model, 2), site_model, tmp_path, symmetry={}).close()
    whole = _cli("state", site_ifc, "--url", tmp_path / "twin.db", "--json")
    assert whole.returncode == 0 and "PARTIAL" not in whole.stderr, whole.stderr
