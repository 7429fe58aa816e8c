"""How fast is an oversized task refused? The issue 21 case: a scene of 300,000 models.

Copies a small task (the bundled ConTRe) to a temporary folder twice, once with a 17.6 MB
scene of 300,000 models (over the 16 MiB file cap) and once with a 12.5 MB one (under the
file cap, over the 250,000-element cap), and prints how long `load_task` takes to refuse
each and how much the peak resident set grew. Before the caps the 18 MB scene cost 8.8 s and
575 MB before an error.

    python benchmarks/hostile_task.py
"""

from __future__ import annotations

import resource
import shutil
import tempfile
import time
from pathlib import Path

from opends_gym.task import TaskError, load_task
from opends_gym.task.bundled import resolve_task_path

MODELS = 300_000


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def refuse(pad: int) -> None:
    src = resolve_task_path("ConTRe").parent
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "task"
        shutil.copytree(src, folder)
        scene = folder / "scene.xml"
        head, tail = scene.read_text(encoding="utf-8").split("<models>", 1)
        model = '<model id="m{}" key="Models/x.j3o"' + " " * pad + "/>\n"
        scene.write_text(head + "<models>" + "".join(model.format(i) for i in range(MODELS)) + tail, encoding="utf-8")
        before = _peak_mb()
        t0 = time.perf_counter()
        try:
            load_task(folder)
            outcome = "loaded (no cap hit!)"
        except TaskError as e:
            outcome = e.reason
        dt = time.perf_counter() - t0
        print(f"{scene.stat().st_size / 1e6:5.1f} MB, {MODELS:,} models: {dt:.3f} s, peak RSS +{_peak_mb() - before:.0f} MB -- {outcome}")


if __name__ == "__main__":
    refuse(pad=18)
    refuse(pad=1)
