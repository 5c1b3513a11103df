"""One rigid-pose rule (``bim2rdt.frames.rigid_problem``, decision 0036): every stage that takes a pose accepts and
refuses the same matrices, so a ``--prior-file`` the CLI accepts is never refused later (it was: the CLI allowed
1e-3 of shear, localization 1e-4, the twin 1e-6)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bim2rdt.bim.writer import _checked_pose as bim_pose
from bim2rdt.errors import Bim2RdtError
from bim2rdt.frames import RIGID_TOLERANCE, rigid_problem
from bim2rdt.localization.core import rigid_prior
from bim2rdt.perception.frame import _rigid
from bim2rdt.registration.validation import _rigid_pose
from bim2rdt.twin.twin import _checked_pose as twin_pose
from bim2rdt.verify import read_prior_file


def _turned(scale: float = 1.0) -> np.ndarray:
    c, s = np.cos(0.7), np.sin(0.7)
    T = np.eye(4)
    T[:3, :3] = scale * np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    T[:3, 3] = (1.0, -4.0, 1.4)
    return T


def _bottom(row) -> np.ndarray:
    T = _turned()
    T[3] = row
    return T


CASES = {
    "exact": (_turned(), True),
    "typed with 3 decimals (4e-4 off)": (_turned(1 + 2e-4), True),
    "scaled 0.5 %": (_turned(1.005), False),
    "mirrored": (np.diag([1.0, 1.0, -1.0, 1.0]), False),
    "bottom row 1 2 3 4": (_bottom([1.0, 2.0, 3.0, 4.0]), False),
    "NaN": (np.full((4, 4), np.nan), False),
}


def _checks(tmp_path):
    def prior_file(T):
        (tmp_path / "prior.json").write_text(json.dumps(np.asarray(T).tolist()))
        return read_prior_file(tmp_path / "prior.json")

    return {"verify --prior-file": prior_file, "localization": rigid_prior, "perception": _rigid,
            "registration": _rigid_pose, "twin": lambda T: twin_pose(T, "pose"), "bim writer": bim_pose}


@pytest.mark.parametrize("name", CASES)
def test_every_pose_check_accepts_and_refuses_the_same_matrices(tmp_path, name):
    T, rigid = CASES[name]
    assert (rigid_problem(T) is None) == rigid
    verdicts = {}
    for stage, check in _checks(tmp_path).items():
        try:
            check(T)
            verdicts[stage] = True
        except Bim2RdtError as error:
            assert len(str(error).splitlines()) == 1
            verdicts[stage] = False
    assert verdicts == dict.fromkeys(verdicts, rigid), verdicts


def test_the_tolerance_sits_between_hand_typed_rotations_and_a_real_scale():
    typed = np.round(_turned()[:3, :3], 3)
    assert np.abs(typed @ typed.T - np.eye(3)).max() < RIGID_TOLERANCE
    assert rigid_problem(_turned(1 + 2 * RIGID_TOLERANCE)) is not None


def test_a_prior_file_the_cli_accepts_localizes_office1(sensors, tmp_path):
    """The truth pose written with 3 decimals (the CLI accepts it; localization refused it before): office1
    localizes from it."""
    from typer.testing import CliRunner

    from bim2rdt.cli import app

    truth = json.loads((sensors / "pcl" / "office1_truth.json").read_text())
    T = np.array(truth["T_world_camera"])
    T[:3, :3] = np.round(T[:3, :3], 3)
    T[:2, 3] += 0.1
    (tmp_path / "prior.json").write_text(json.dumps(T.tolist()))
    assert np.abs(T[:3, :3] @ T[:3, :3].T - np.eye(3)).max() > 1e-4  # what localization refused
    g = ",".join(str(x) for x in truth["depth_correction"]["g"])
    result = CliRunner().invoke(app, ["verify", str(sensors / "pcl" / "office1.ifc"), str(sensors / "pcl" /
                                      "office1.pcd"), "--prior-file", str(tmp_path / "prior.json"),
                                      "--depth-correction", g, "--out", str(tmp_path / "out"), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["localized"] == 1
