"""Export a drive as OpenDS analyzer files: carData.txt, reactionData.xml, drivingTaskLog.txt.

Why: so our drives open in OpenDS's Drive Analyzer and in scripts written for OpenDS
output folders (`analyzerData/<date>/`). Existing files are never overwritten.

A carData row holds the car's state and the inputs set on it at that moment, which drive it
from that row on (`DataWriter.saveAnalyzerData` reads `car.getSteeringWheelState()` beside the
position; a log is replayed so, each row's inputs held to the next: `data.episodes`, `record.conform`).
A recording's `/ego` sample holds the state after a physics step and the inputs of that step,
the ones that led to it: each row is written with the inputs of the sample after it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .cardata import write_cardata
from .drive import Drive
from .opends_logs import write_driving_task_log, write_reaction_data

FILES = ("carData.txt", "reactionData.xml", "drivingTaskLog.txt")


def export_opends(drive: Drive, folder: str | Path) -> list[Path]:
    """Write the three files into `folder` (created); refuses to overwrite any of them."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    clash = [name for name in FILES if (out / name).exists()]
    if clash:
        raise FileExistsError(f"{out}: {', '.join(clash)} already exist; choose an empty folder")
    c = drive.columns
    task = str(drive.meta.get("task_path") or drive.meta.get("driving_task") or drive.meta.get("task_name") or "")
    driver = str(drive.meta.get("driver") or drive.meta.get("env_id") or "opends_gym")
    quat = np.column_stack([c["qx"], c["qy"], c["qz"], c["qw"]])
    steering, accelerator, brake = (inputs_from_here(c[k]) for k in ("steering", "accelerator", "brake"))
    written = [
        write_cardata(
            out / "carData.txt",
            c["t_s"],
            c["x_m"],
            c["y_m"],
            c["z_m"],
            quat,
            c["speed_kmh"],
            steering,
            accelerator,
            brake,
            np.nan_to_num(c["engine_on"], nan=1.0) > 0.5,
            driving_task=task,
            driver=driver,
            start_epoch_ms=drive.start_epoch_ms,
        ),
        write_reaction_data(out / "reactionData.xml", drive.reactions, drive.start_epoch_ms),
        write_driving_task_log(
            out / "drivingTaskLog.txt", drive.events, drive.reactions, driver=driver, driving_task=task, start_epoch_ms=drive.start_epoch_ms
        ),
    ]
    return written


def inputs_from_here(column: np.ndarray) -> np.ndarray:
    """A recorded input column as carData rows hold it: at each sample, the input of the step
    after it (the one it drives on from there), the last sample keeping its own."""
    c = np.asarray(column, dtype=float)
    return np.concatenate([c[1:], c[-1:]]) if len(c) else c
