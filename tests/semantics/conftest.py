"""Fixtures of the semantics tests: a local OpenAI-compatible server (see fake_llm_server.py)."""

from __future__ import annotations

import pytest
from fake_llm_server import FakeLlmServer


@pytest.fixture
def llm_server():
    with FakeLlmServer() as server:
        yield server
