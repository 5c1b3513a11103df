"""Errors of the sensor readers."""

from __future__ import annotations

from pathlib import Path

from bim2rdt.errors import Bim2RdtError


class SourceError(Bim2RdtError):
    """A recording, frame or scan that cannot be read as it is: one line naming the file and what is wrong.

    Args:
        path: The file or folder that cannot be read.
        problem: What is wrong with it, in a few words.
    """

    def __init__(self, path: str | Path, problem: str) -> None:
        self.path, self.problem = str(path), problem
        super().__init__(f"{path}: {problem}")
