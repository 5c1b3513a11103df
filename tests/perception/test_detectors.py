"""The detector registry: every name the demo and the CLI accept, checked once, built in one place."""

from __future__ import annotations

import pytest

from bim2rdt.perception import GeometricDetector, PerceptionError
from bim2rdt.perception.detectors import DETECTORS, check_detector, make_detector


def test_an_unknown_name_is_a_one_line_error_that_lists_the_detectors():
    with pytest.raises(PerceptionError, match="unknown detector 'oracle'; choose one of geometric, yoloe, ideal"):
        check_detector("oracle")
    with pytest.raises(ValueError):  # and still a ValueError, for callers that catch that
        make_detector("oracle", None, {})


def test_yoloe_needs_both_local_files(tmp_path):
    with pytest.raises(PerceptionError, match="--yoloe-weights"):
        check_detector("yoloe")
    with pytest.raises(PerceptionError, match="--yoloe-embeddings"):
        check_detector("yoloe", (tmp_path / "w.pt", None))
    check_detector("yoloe", (tmp_path / "w.pt", tmp_path / "e.npz"))  # the files are the detector's to read


def test_each_name_builds_its_detector_and_the_ideal_one_only_where_a_simulation_hands_it_in(site_model):
    assert DETECTORS[0] == "geometric"
    assert isinstance(make_detector("geometric", site_model, {}), GeometricDetector)
    sentinel = object()
    assert make_detector("ideal", site_model, {}, ideal=lambda: sentinel) is sentinel
    with pytest.raises(PerceptionError, match="simulated site"):
        make_detector("ideal", site_model, {})
