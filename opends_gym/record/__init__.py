"""Drive recording (MCAP), exact replay, the Drive Analyzer and OpenDS file interchange.

Public API:
* `DriveRecorder`, `attach_recorder` -- record a World (any driver) to MCAP;
* `RecordDrive` -- Gymnasium wrapper: one replayable MCAP file per episode;
* `read_recording` -- read a recording back (also one cut short by a crash);
* `replay`, `replay_to` -- re-simulate a recording, check it bit for bit, stop at a time;
* `load_drive`, `analyze`, `write_report` (matplotlib, imported on first use) -- the analyzer
  for MCAP recordings and OpenDS carData.txt;
* `read_cardata`, `write_cardata`, `read_reaction_data`, `write_reaction_data`,
  `write_driving_task_log`, `export_opends` -- OpenDS's analyzer files.
"""

from __future__ import annotations

from typing import Any

from .analyze import analyze
from .cardata import read_cardata, write_cardata
from .drive import load_drive
from .export import export_opends
from .mcap_io import Recording, read_recording
from .opends_logs import read_reaction_data, write_driving_task_log, write_reaction_data
from .recorder import DriveRecorder, attach_recorder
from .replay import replay, replay_to
from .wrapper import RecordDrive

__all__ = [
    "DriveRecorder",
    "RecordDrive",
    "Recording",
    "analyze",
    "attach_recorder",
    "export_opends",
    "load_drive",
    "read_cardata",
    "read_reaction_data",
    "read_recording",
    "replay",
    "replay_to",
    "write_cardata",
    "write_driving_task_log",
    "write_reaction_data",
    "write_report",
]


def __getattr__(name: str) -> Any:
    if name == "write_report":  # keeps matplotlib out of plain recording
        from .report import write_report

        return write_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
