"""Walking an MCAP file record by record, telling a file cut short from a damaged one.

Why: a recording is the experiment's evidence. A file cut short by a crash ends in a torn
record and its intact prefix is worth reading; a byte flipped in the middle of a complete
file is damage, and reading on past it (or stopping there and calling it "cut short") hides
it. So every top-level record's place is known, and the checks MCAP provides are made:
chunk CRCs (over the uncompressed records), attachment CRCs, the data-section CRC in
DataEnd, the summary CRC in the Footer, and the closing magic.

Classification: a record that runs past the end of the file is *torn* (truncation) unless
the file ends in a valid Footer and magic, in which case it is *corrupt*; a record that lies
wholly inside the file but fails to parse or to match its CRC is *corrupt*.
"""

from __future__ import annotations

import io
import struct
import zlib
from collections.abc import Iterator
from typing import IO, Any

from mcap.data_stream import ReadDataStream
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import breakup_chunk

MAGIC = b"\x89MCAP0\r\n"
_FOOTER_BYTES = 1 + 8 + 20  # opcode, length, summary_start, summary_offset_start, summary_crc
_READERS: dict[int, Any] = {
    1: Header,
    2: Footer,
    3: Schema,
    4: Channel,
    5: Message,
    6: Chunk,
    7: MessageIndex,
    8: ChunkIndex,
    9: Attachment,
    10: AttachmentIndex,
    11: Statistics,
    12: Metadata,
    13: MetadataIndex,
    14: SummaryOffset,
    15: DataEnd,
}


class Torn(Exception):
    """The file ends inside the record at `offset` (cut short)."""

    def __init__(self, offset: int, reason: str) -> None:
        super().__init__(reason)
        self.offset = offset


class Corrupt(Exception):
    """The record at `offset` lies in the file but is damaged."""

    def __init__(self, offset: int, reason: str) -> None:
        super().__init__(reason)
        self.offset = offset


def not_mcap_reason(head: bytes) -> str | None:
    """Why a file starting with `head` is not MCAP, or None when the magic is there."""
    if not head:
        return "empty file"
    if len(head) < len(MAGIC):
        return f"only {len(head)} bytes, shorter than the MCAP magic"
    if head[: len(MAGIC)] != MAGIC:
        return f"it starts with {head[:8]!r}, not the MCAP magic"
    return None


def has_footer(f: IO[bytes], size: int) -> bool:
    """Whether the file ends in a Footer record and the closing magic (finish() ran)."""
    if size < len(MAGIC) * 2 + _FOOTER_BYTES:
        return False
    f.seek(size - len(MAGIC) - _FOOTER_BYTES)
    tail = f.read(_FOOTER_BYTES + len(MAGIC))
    return tail[0] == 2 and struct.unpack_from("<Q", tail, 1)[0] == 20 and tail[-len(MAGIC) :] == MAGIC


def walk(f: IO[bytes], size: int) -> Iterator[tuple[int, Any]]:
    """(offset, record) of every record after the magic, chunks opened and checked.

    Raises Torn or Corrupt (with the offset of the record) when the file cannot be read on."""
    complete = has_footer(f, size)
    f.seek(len(MAGIC))
    crc: int | None = zlib.crc32(MAGIC)
    offset = len(MAGIC)
    while True:
        head = f.read(9)
        if len(head) < 9 or offset + 9 + struct.unpack_from("<Q", head + bytes(9), 1)[0] > size:
            why = f"the record at byte {offset} runs past the end of the file ({size} bytes)"
            if complete:
                raise Corrupt(offset, why + " although the file has its footer")
            raise Torn(offset, why)
        opcode, length = struct.unpack("<BQ", head)
        content = f.read(length)
        cls = _READERS.get(opcode)
        if cls is None:
            raise Corrupt(offset, f"unknown record opcode 0x{opcode:02x}")
        try:
            stream = ReadDataStream(io.BytesIO(content))
            record = cls.read(stream, length) if cls is Message else cls.read(stream)
        except Exception as e:
            raise Corrupt(offset, f"unreadable {cls.__name__} record ({type(e).__name__}: {e})") from e
        yield from _checked(offset, record, content, crc)
        if isinstance(record, Footer):
            _check_footer(f, offset, size, record)
            return
        if isinstance(record, DataEnd):
            crc = None  # the summary section is covered by the footer's CRC
        elif crc is not None:
            crc = zlib.crc32(head + content, crc)
        offset += 9 + length


def _checked(offset: int, record: Any, content: bytes, crc: int | None) -> Iterator[tuple[int, Any]]:
    if isinstance(record, Chunk):
        try:
            inner = breakup_chunk(record, validate_crc=True)
        except Exception as e:
            raise Corrupt(offset, f"damaged chunk of {len(content)} bytes ({type(e).__name__}: {e})") from e
        for r in inner:
            yield offset, r
        return
    if isinstance(record, Attachment):  # (mcap's reader skips this CRC: it is the record's last 4 bytes)
        stored = struct.unpack_from("<I", content, len(content) - 4)[0] if len(content) >= 4 else 0
        if stored and zlib.crc32(content[:-4]) != stored:
            raise Corrupt(offset, f"attachment '{record.name}' fails its CRC")
    if isinstance(record, DataEnd) and record.data_section_crc and crc is not None and record.data_section_crc != crc:
        raise Corrupt(offset, f"the data section (bytes 0..{offset}) fails its CRC in DataEnd")
    yield offset, record


def _check_footer(f: IO[bytes], offset: int, size: int, footer: Footer) -> None:
    if f.read(len(MAGIC)) != MAGIC:
        raise Corrupt(offset, "no closing MCAP magic after the footer")
    start = footer.summary_start
    if footer.summary_crc and start:
        if not 0 < start <= offset:
            raise Corrupt(offset, f"the footer's summary start {start} is outside the file")
        f.seek(start)
        data = f.read(offset + 9 + 16 - start)  # summary section through summary_offset_start
        if zlib.crc32(data) != footer.summary_crc:
            raise Corrupt(start, f"the summary section (bytes {start}..{size}) fails the footer's CRC")
