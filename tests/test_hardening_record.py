"""Damaged recordings (issue 21, case 7): a byte flipped anywhere in an MCAP recording is
reported as corruption with its byte offset (chunk, attachment, data-section and summary
CRCs), `replay --check` and `analyze` fail on it, a file cut short still reads as a prefix,
and empty or foreign `.mcap` files are named as such instead of going to the carData parser."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from opends_gym.cli.main import main
from opends_gym.record import read_recording
from opends_gym.record.drive import load_drive
from opends_gym.record.mcap_io import CorruptRecordingError


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "drive.mcap"
    assert main(["run", "OpenDS/LaneChangeTest-v0", "--agent", "constant:0.01,1", "--max-seconds", "3", "--record", str(path)]) == 0
    return path


def _flipped(src: Path, dst: Path, pos: int, bit: int) -> Path:
    data = bytearray(src.read_bytes())
    data[pos] ^= 1 << bit
    dst.write_bytes(bytes(data))
    return dst


def test_every_flipped_byte_is_reported_as_corruption_with_its_offset(recording: Path, tmp_path: Path) -> None:
    size = recording.stat().st_size
    rng = random.Random(21)
    for _ in range(60):
        pos = rng.randrange(8, size)  # (a flip in the leading magic is "not an MCAP recording")
        bad = _flipped(recording, tmp_path / "bad.mcap", pos, rng.randrange(8))
        with pytest.raises(CorruptRecordingError) as info:
            read_recording(bad)
        assert 8 <= info.value.offset < size and f"at byte {info.value.offset}" in str(info.value)


def test_salvage_reads_the_messages_before_the_damage(recording: Path, tmp_path: Path) -> None:
    full = read_recording(recording)
    size = recording.stat().st_size
    # inside a chunk (with /tf and the Foxglove schemas, the last quarter of this 3 s file is its summary)
    bad = _flipped(recording, tmp_path / "bad.mcap", size // 2, 3)
    part = read_recording(bad, salvage=True)
    assert part.corrupt_at is not None and not part.complete and "corrupt" in part.problem
    n = len(part.topic("/ego"))
    assert n < len(full.topic("/ego")) and part.topic("/ego") == full.topic("/ego")[:n]


def test_replay_check_and_analyze_fail_on_a_damaged_file(recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["analyze", str(recording)]) == 0
    out = capsys.readouterr().out
    assert "cut short" not in out  # the footer is there
    bad = _flipped(recording, tmp_path / "bad.mcap", recording.stat().st_size // 2, 5)
    assert main(["replay", str(bad), "--check"]) != 0
    assert "corrupt recording at byte" in capsys.readouterr().err
    assert main(["analyze", str(bad)]) != 0
    err = capsys.readouterr().err
    assert "corrupt recording at byte" in err and "cut short" not in err


def test_a_file_cut_anywhere_reads_back_as_a_prefix(recording: Path, tmp_path: Path) -> None:
    data = recording.read_bytes()
    full = read_recording(recording).topic("/ego")
    cut = tmp_path / "cut.mcap"
    prefixes = 0
    for n in range(9, len(data) - 1, max(1, len(data) // 40)):
        cut.write_bytes(data[:n])
        try:
            rec = read_recording(cut)
        except CorruptRecordingError as e:  # pragma: no cover - the failure this test is for
            raise AssertionError(f"a file cut at byte {n} was called corrupt: {e}") from e
        except ValueError as e:  # cut before the metadata record: nothing to read yet
            assert "without opends_gym metadata" in str(e)
            continue
        assert not rec.complete and "runs past the end of the file" in rec.problem
        ego = rec.topic("/ego")
        assert ego == full[: len(ego)]
        prefixes += 1
    assert prefixes >= 30


@pytest.mark.parametrize(
    ("content", "reason"),
    [(b"", "empty file"), (b"\x89MC", "only 3 bytes"), (b"PK\x03\x04 a zip file, really", "not the MCAP magic")],
)
def test_empty_or_foreign_mcap_files_are_named(tmp_path: Path, content: bytes, reason: str) -> None:
    path = tmp_path / "x.mcap"
    path.write_bytes(content)
    for read in (read_recording, load_drive):
        with pytest.raises(ValueError, match=rf"x\.mcap: not an MCAP recording \(.*{reason}"):
            read(path)
