"""Reading back the Nav2 map files the planner writes (a test helper: the library writes maps, it never reads
them)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def read_pgm(path: Path) -> np.ndarray:
    """A binary (P5) 8-bit PGM as uint8 (rows, cols), first row at the image's top; comments allowed anywhere in
    the header."""
    data = Path(path).read_bytes()
    fields, position = [], 0
    while len(fields) < 4:
        while data[position:position + 1].isspace():
            position += 1
        if data[position:position + 1] == b"#":
            position = data.index(b"\n", position) + 1
            continue
        end = position
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[position:end])
        position = end
    assert fields[0] == b"P5" and int(fields[3]) <= 255, f"{path}: not an 8-bit binary PGM"
    width, height = int(fields[1]), int(fields[2])
    return np.frombuffer(data[position + 1:position + 1 + width * height], np.uint8).reshape(height, width)
