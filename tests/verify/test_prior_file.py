"""Hostile ``--prior-file``s: each is refused in one line by the real entry point (exit 1, no traceback, no
RuntimeWarning, none of the file's text echoed), before the model is loaded, and leaves no empty ``--out``."""

from __future__ import annotations

import json
import sys
import warnings

import pytest

from bim2rdt.cli import main

EYE = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]


def _with(**rows) -> str:
    matrix = [list(row) for row in EYE]
    for index, row in rows.items():
        matrix[int(index[1:])] = row
    return json.dumps(matrix)


CASES = {
    "nested 100,000 deep": ("[" * 100_000 + "]" * 100_000, "too large"),
    "nested 5,000 deep": ("[" * 5_000 + "]" * 5_000, "nested too deep"),
    "bottom row 1 2 3 4": (_with(r3=[1, 2, 3, 4]), "last row is not 0 0 0 1"),
    "NaN": (_with(r0=[float("nan"), 0, 0, 0]), "NaN or infinite"),
    "Infinity": (_with(r1=[0, float("inf"), 0, 0]), "NaN or infinite"),
    "1e999 overflows to inf": ("[[1e999, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]", "NaN or infinite"),
    "a 1e308 translation": (_with(r0=[1, 0, 0, 1e308]), "translation is over"),
    "strings": (json.dumps([["hunter2-secret"] * 4] * 4), "expected numbers"),
    "a string": (json.dumps("hunter2-secret"), "expected a 4x4 matrix"),
    "not JSON": ("hunter2-secret {", "not valid JSON"),
    "3x3": (json.dumps([[1, 0, 0], [0, 1, 0], [0, 0, 1]]), "expected a 4x4 matrix"),
}


@pytest.mark.parametrize("name", CASES)
def test_a_hostile_prior_file_is_one_line_exit_1_and_no_empty_out(tmp_path, monkeypatch, capsys, name):
    text, expected = CASES[name]
    (tmp_path / "prior.json").write_text(text)
    out = tmp_path / "out"
    monkeypatch.setattr(sys, "argv", ["bim2rdt", "verify", str(tmp_path / "model.ifc"), str(tmp_path / "f.pcd"),
                                      "--prior-file", str(tmp_path / "prior.json"), "--out", str(out)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning (overflow) fails the test
        with pytest.raises(SystemExit) as done:
            main()
    captured = capsys.readouterr()
    message = (captured.out + captured.err).strip()
    assert done.value.code == 1, message
    assert len(message.splitlines()) == 1 and "Traceback" not in message, message
    assert expected in message and "hunter2" not in message, message
    assert not out.exists()  # a failed run leaves no empty --out folder


def test_a_failed_verify_keeps_an_existing_out_folder_and_its_files(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "earlier.txt").write_text("kept")
    (tmp_path / "prior.json").write_text(_with(r3=[1, 2, 3, 4]))
    monkeypatch.setattr(sys, "argv", ["bim2rdt", "verify", str(tmp_path / "model.ifc"), str(tmp_path / "f.pcd"),
                                      "--prior-file", str(tmp_path / "prior.json"), "--out", str(out)])
    with pytest.raises(SystemExit):
        main()
    assert (out / "earlier.txt").read_text() == "kept"
