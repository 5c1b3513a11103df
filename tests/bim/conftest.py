"""Fixtures of the BIM tests: each real sample read once per session (Office_A alone tessellates for ~7 s), with
its own cache folder. The embedded site (``site_ifc``, ``site_model``) comes from tests/conftest.py."""

from __future__ import annotations

import re

import pytest

from bim2rdt.bim import load_ifc


@pytest.fixture(scope="session")
def sample_model(samples, tmp_path_factory):
    """load_ifc of a shared sample by file name, tessellated once per session."""
    cache_dir = tmp_path_factory.mktemp("samples-cache")
    models = {}

    def load(name: str):
        if name not in models:
            models[name] = load_ifc(samples / name, cache_dir=cache_dir)
        return models[name]

    return load


class SiteText:
    """The embedded site's STEP text, and the edits the reader tests make to it (each test gets its own copy)."""

    def __init__(self, text: str, folder):
        self.text, self.folder = text, folder

    def line(self, pattern: str) -> str:
        """The first line matching a regex, e.g. ``r"=IFCWALL\\("``."""
        return next(line for line in self.text.splitlines() if re.search(pattern, line))

    def line_number(self, line: str) -> int:
        return self.text.splitlines().index(line) + 1

    def entity_id(self, line: str) -> int:
        return int(re.match(r"#(\d+)", line).group(1))

    def replace(self, old: str, new: str, name: str = "variant.ifc"):
        """Write the site with one exact text replaced; returns the file's path."""
        assert self.text.count(old) >= 1, old
        path = self.folder / name
        path.write_text(self.text.replace(old, new, 1), encoding="utf-8")
        return path


@pytest.fixture
def site_text(site_ifc, tmp_path) -> SiteText:
    return SiteText(site_ifc.read_text(encoding="utf-8"), tmp_path)
