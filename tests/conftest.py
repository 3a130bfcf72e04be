"""The suite's order: the slow tests first, so that when the suite runs on several cores
(`scripts/test`: pytest-xdist handing out a test or two at a time) no core is left with a long
test at the end while the others idle."""

from __future__ import annotations

import pytest


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)  # stable: files keep their order
