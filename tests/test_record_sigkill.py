"""A recording process killed with SIGKILL leaves a file that reads back up to its last flush.

The child records an endless-looking drive (throttled so the parent can catch it mid-run)
and prints, after every flush, the simulation time and message count that reached the OS.
The parent kills it with SIGKILL after a few flushes and reads the file: no footer, but at
least every message up to the last reported flush, and the drive still replays exactly.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from opends_gym.record import read_recording
from opends_gym.record.replay import replay

CHILD = textwrap.dedent(
    """
    import logging, sys, time
    logging.disable(logging.WARNING)
    import numpy as np, gymnasium as gym
    import opends_gym
    from opends_gym.record import RecordDrive

    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", max_episode_s=10000.0), sys.argv[1], flush_interval_s=0.5)
    env.reset(seed=5)
    action = np.array([0.0, 1.0], dtype=np.float32)
    last = None
    while True:
        env.step(action)
        sink = env.recorder.sink
        if sink.flushed_t_ns != last:
            last = sink.flushed_t_ns
            print(f"FLUSHED {sink.flushed_t_ns} {sink.flushed_messages}", flush=True)
        time.sleep(0.004)  # about 25x real time: the parent kills it long before the track ends
    """
)


def test_sigkilled_recorder_leaves_a_readable_file_up_to_its_last_flush(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(path)], stdout=subprocess.PIPE, text=True, cwd=tmp_path)
    flushed_ns, flushed_msgs, flushes = 0, 0, 0
    deadline = time.monotonic() + 120.0
    try:
        assert proc.stdout is not None
        while flushed_ns < 4_000_000_000 and time.monotonic() < deadline:
            line = proc.stdout.readline()
            assert line, f"the recorder ended before it was killed (exit {proc.poll()})"
            if line.startswith("FLUSHED"):
                _, t, n = line.split()
                flushed_ns, flushed_msgs = int(t), int(n)
                flushes += 1
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    assert flushes >= 8 and flushed_ns >= 4_000_000_000
    rec = read_recording(path)
    assert not rec.complete, "killed before finish(): no summary or footer"
    total = sum(len(v) for v in rec.messages.values())
    assert total >= flushed_msgs, "every message written before the last flush is in the file"
    ego_times = [t for t, _ in rec.messages["/ego"]]
    assert ego_times[-1] >= flushed_ns, "flushes come after whole physics steps"
    assert len(ego_times) >= flushed_ns * 60 // 1_000_000_000  # 60 Hz from t = 1/60 s
    assert [e["step"] for e in rec.topic("/ego")] == list(range(1, len(ego_times) + 1))
    result = replay(rec)
    result.close()
    assert result.ok, str(result.mismatch)
