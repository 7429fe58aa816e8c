"""MCAP on disk: a crash-safe writer and a reader that tolerates a missing footer.

Why: a recording is the experiment's data; a crashed or killed session must not lose it.
The writer puts the header, the metadata and the attachment on disk at once, closes a
chunk and flushes the file every `flush_interval_s` of simulation time (and whenever a
chunk fills), so a SIGKILL loses at most the last interval. `finish()` adds the summary
and footer. The reader walks the file record by record (`mcap_walk`) and stops
cleanly at a torn record, so a file without a summary reads back up to its last flush;
`Recording.complete` says whether the footer was there. Damage inside the file (a chunk,
attachment, data-section or summary CRC that does not match) is an error naming its byte.

mcap facts used: log times are integer nanoseconds (we use simulation time); chunked
writing only reaches the file when a chunk is closed, which `mcap.writer.Writer` does for
full chunks and, for our timed flushes, through its (private) chunk finalizer; should a
future mcap drop that method we fall back to unchunked writing, which flushes every record.
"""

from __future__ import annotations

import io
import json
import logging
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.records import Attachment, Channel, Footer, Header, Message, Metadata
from mcap.writer import CompressionType, Writer

from .mcap_walk import MAGIC, Corrupt, Torn, not_mcap_reason, walk
from .messages import encode
from .schemas import schema_bytes

log = logging.getLogger(__name__)

META_NAME = "opends_gym"
CONFIG_ATTACHMENT = "opends_gym_config.json"
DEFAULT_CHUNK_BYTES = 256 * 1024


def _compression() -> CompressionType:
    try:
        import zstandard  # noqa: F401

        return CompressionType.ZSTD
    except ImportError:  # pragma: no cover - depends on the environment
        return CompressionType.NONE


def create_unique(path: str | Path, suffix_tag: str = "") -> tuple[Path, io.BufferedWriter]:
    """Create a new file that did not exist: `name<tag>.mcap`, then `name<tag>(2).mcap`, ...

    OpenDS appends `(2)`, `(3)` the same way. The file is claimed with exclusive creation,
    so two recorders racing for a name never overwrite each other (or an old recording).
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    stem, ext = p.stem + suffix_tag, p.suffix or ".mcap"
    k = 1
    while True:
        candidate = p.with_name(f"{stem}{ext}" if k == 1 else f"{stem}({k}){ext}")
        try:
            return candidate, open(candidate, "xb")
        except FileExistsError:
            k += 1


class McapSink:
    """One recording file being written (JSON-encoded channels, registered on first use)."""

    def __init__(
        self,
        path: str | Path,
        meta: dict[str, Any],
        *,
        start_ns: int = 0,
        flush_interval_s: float = 1.0,
        fsync: bool = False,
        chunk_bytes: int = DEFAULT_CHUNK_BYTES,
        suffix_tag: str = "",
    ) -> None:
        created, self._file = create_unique(path, suffix_tag)
        self.path: Path | None = created
        self.flush_interval_ns = int(flush_interval_s * 1e9)
        self.fsync = fsync
        # data-section CRC on: with the chunk CRCs it lets the reader tell damage from truncation
        self._writer = Writer(self._file, chunk_size=chunk_bytes, compression=_compression(), enable_data_crcs=True)
        self._finalize_chunk = getattr(self._writer, "_Writer__finalize_chunk", None)
        if self._finalize_chunk is None:  # pragma: no cover - only with a future mcap
            log.warning("mcap.Writer has no chunk finalizer; writing unchunked so every record is flushed")
            self._writer = Writer(self._file, use_chunking=False, compression=CompressionType.NONE)
        self._writer.start(profile="", library=f"opends_gym {meta.get('software_version', '')}".strip())
        self._writer.add_metadata(META_NAME, {k: v if isinstance(v, str) else json.dumps(v, default=str) for k, v in meta.items()})
        config = json.dumps(meta, indent=1, sort_keys=True, default=str).encode()
        self._writer.add_attachment(create_time=0, log_time=start_ns, name=CONFIG_ATTACHMENT, media_type="application/json", data=config)
        self._channels: dict[str, int] = {}
        self._seq = 0
        self._last_flush_ns = start_ns
        self.messages = 0
        self.flushed_messages = 0
        self.flushed_t_ns = start_ns
        self.closed = False
        self._flush()

    def _channel(self, topic: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            name, data = schema_bytes(topic)
            sid = self._writer.register_schema(name=name, encoding="jsonschema", data=data)
            cid = self._writer.register_channel(topic=topic, message_encoding="json", schema_id=sid)
            self._channels[topic] = cid
        return cid

    def write(self, topic: str, t_ns: int, msg: dict[str, Any]) -> None:
        if self.closed:
            return
        self._seq += 1
        self._writer.add_message(channel_id=self._channel(topic), log_time=t_ns, publish_time=t_ns, data=encode(msg), sequence=self._seq)
        self.messages += 1

    def flush_if_due(self, t_ns: int) -> None:
        """Flush when `flush_interval_s` of simulation time has passed (called after whole steps)."""
        if t_ns - self._last_flush_ns >= self.flush_interval_ns:
            self.flush(t_ns)

    def flush(self, t_ns: int | None = None) -> None:
        """Close the open chunk and push everything to the OS (survives a killed process)."""
        if self.closed:
            return
        if self._finalize_chunk is not None:
            self._finalize_chunk()
        self._flush()
        self.flushed_messages = self.messages
        if t_ns is not None:
            self._last_flush_ns = t_ns
            self.flushed_t_ns = t_ns

    def _flush(self) -> None:
        self._file.flush()
        if self.fsync:
            os.fsync(self._file.fileno())

    def close(self) -> None:
        """Write the summary and footer (the file is complete and indexed)."""
        if self.closed:
            return
        try:
            self._writer.finish()
            self._flush()
        finally:
            self.closed = True
            self._file.close()


class MemorySink:
    """Collects messages instead of writing them (replay's checker)."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, int, Any]] = []
        self.closed = False
        self.path: Path | None = None
        self.flushed_messages = 0
        self.flushed_t_ns = 0

    def write(self, topic: str, t_ns: int, msg: dict[str, Any]) -> None:
        if not self.closed:
            self.messages.append((topic, t_ns, json.loads(encode(msg))))

    def flush(self, t_ns: int | None = None) -> None:
        pass

    def flush_if_due(self, t_ns: int) -> None:
        pass

    def close(self) -> None:
        self.closed = True


# ------------------------------------------------------------------ reading
@dataclass
class Recording:
    """A recording read back: metadata, and the messages of each topic in file order."""

    path: Path
    meta: dict[str, Any]
    messages: dict[str, list[tuple[int, Any]]] = field(default_factory=dict)  # topic -> [(log_time_ns, decoded)]
    attachments: dict[str, bytes] = field(default_factory=dict)
    complete: bool = False  # footer present (finish() ran)
    problem: str = ""  # why reading stopped early (a torn last record, or damage with salvage=True)
    corrupt_at: int | None = None  # byte offset of the damaged record (salvage=True only)

    def topic(self, name: str) -> list[Any]:
        return [m for _, m in self.messages.get(name, [])]

    @property
    def duration_s(self) -> float:
        times = [t for msgs in self.messages.values() for t, _ in msgs]
        return (max(times) - min(times)) / 1e9 if times else 0.0


_JSON_KEYS = re.compile(
    r"^(seed|env_kwargs|reset_options|world_config|analysis|analysis_lct|episode|ego_rate_hz|physics_hz|segment|track|start_step|replayable)$"
)


def _decode_meta(raw: dict[str, str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in raw.items():
        if _JSON_KEYS.match(k):
            try:
                out[k] = json.loads(v)
                continue
            except ValueError:
                pass
        out[k] = v
    return out


class CorruptRecordingError(ValueError):
    """A recording damaged in the middle (not merely cut short); `offset` is the damaged record's byte."""

    def __init__(self, path: Path, offset: int, reason: str) -> None:
        super().__init__(f"{path}: corrupt recording at byte {offset}: {reason}")
        self.path, self.offset, self.reason = path, offset, reason


def read_recording(path: str | Path, topics: Iterable[str] | None = None, *, salvage: bool = False) -> Recording:
    """Read an MCAP recording, complete or cut short (killed writer, full disk).

    Raises ValueError naming the file (and why) when it is not an MCAP file at all, and
    `CorruptRecordingError` naming the byte offset when a record in the file is damaged
    (chunk, attachment, data-section or summary CRC, or an unreadable record); with
    `salvage=True` the messages before the damage are returned instead, with
    `Recording.corrupt_at` and `problem` set.
    """
    p = Path(path)
    wanted = set(topics) if topics is not None else None
    rec = Recording(p, {})
    channels: dict[int, Channel] = {}
    size = p.stat().st_size
    with open(p, "rb") as f:
        why = not_mcap_reason(f.read(len(MAGIC)))
        if why is not None:
            raise ValueError(f"{p}: not an MCAP recording ({why})")
        records = walk(f, size)
        try:
            first = next(records, None)
            if first is None or not isinstance(first[1], Header):
                raise ValueError(f"{p}: not an MCAP recording (no header record after the magic)")
            for _, r in records:
                if isinstance(r, Message):
                    ch = channels.get(r.channel_id)
                    if ch is None:
                        raise ValueError(f"message on unknown channel {r.channel_id}")
                    if wanted is None or ch.topic in wanted:
                        rec.messages.setdefault(ch.topic, []).append((r.log_time, json.loads(r.data)))
                elif isinstance(r, Channel):
                    channels[r.id] = r
                elif isinstance(r, Metadata) and r.name == META_NAME:
                    rec.meta = _decode_meta(dict(r.metadata))
                elif isinstance(r, Attachment):
                    rec.attachments[r.name] = bytes(r.data)
                elif isinstance(r, Footer):
                    rec.complete = True
        except Torn as e:  # a torn last record: keep everything before it
            rec.problem = str(e)
            log.info("%s: read up to a torn record (%s)", p, rec.problem)
        except Corrupt as e:
            if not salvage:
                raise CorruptRecordingError(p, e.offset, str(e)) from e
            rec.corrupt_at, rec.problem = e.offset, f"corrupt at byte {e.offset}: {e}"
        except ValueError as e:  # a record that parsed but means nothing (bad JSON, unknown channel)
            if str(e).startswith(str(p)):
                raise
            if not salvage:
                raise CorruptRecordingError(p, f.tell(), str(e)) from e
            rec.corrupt_at, rec.problem = f.tell(), f"corrupt near byte {f.tell()}: {e}"
    config = rec.attachments.get(CONFIG_ATTACHMENT)
    if config is not None:  # the exact JSON; the metadata record holds the same as strings
        try:
            rec.meta = json.loads(config)
        except ValueError:
            log.warning("%s: unreadable %s attachment; using the metadata record", p, CONFIG_ATTACHMENT)
    if not rec.meta:
        raise ValueError(f"{p}: MCAP file without opends_gym metadata (not a drive recording)")
    return rec
