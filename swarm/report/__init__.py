"""Figures and reports: what people look at.

`build_report(path)` turns a plan, a simulation log, a study or a model validation on disk into a
`Report` (`.kind`, `.data`, `.html()`, `.markdown()`, `.json()`, `.write(path)`); see
`swarm.report.load`. Imported lazily, so `swarm.report.style` stays light for the simulator.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from swarm.report.document import Report

__all__ = ["Report", "build_report"]


def build_report(path: str | Path, *, date: str | None = None) -> Report:
    """The report of the plan, simulation log, study or validation at `path` (folder or file)."""
    from swarm.report.load import report_for

    return report_for(path, date=date)


def __getattr__(name: str):
    if name == "Report":
        from swarm.report.document import Report

        return Report
    raise AttributeError(f"module 'swarm.report' has no attribute {name!r}")
