"""Fixtures for the simulator tests: the tiny mission as a file."""

from __future__ import annotations

from pathlib import Path

import pytest
from tiny_missions import write_mission


@pytest.fixture(scope="session")
def tiny_mission(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The BASE mission as a file."""
    return write_mission(tmp_path_factory.mktemp("missions"))
