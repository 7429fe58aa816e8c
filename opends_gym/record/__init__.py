"""Drive recording (MCAP), exact replay, the Drive Analyzer and OpenDS file interchange.

Public API:
* `DriveRecorder`, `attach_recorder` -- record a World (any driver) to MCAP;
* `RecordDrive` -- Gymnasium wrapper: one replayable MCAP file per episode;
* `read_recording` -- read a recording back (also one cut short by a crash);
* `replay`, `replay_to` -- re-simulate a recording, check it bit for bit, stop at a time;
* `load_drive`, `analyze`, `write_report` -- the analyzer (MCAP or OpenDS carData.txt);
* `read_cardata`, `write_cardata`, `write_reaction_data`, `write_driving_task_log`.
"""

from __future__ import annotations

from .mcap_io import Recording, read_recording
from .recorder import DriveRecorder, attach_recorder
from .wrapper import RecordDrive

__all__ = ["DriveRecorder", "RecordDrive", "Recording", "attach_recorder", "read_recording"]
