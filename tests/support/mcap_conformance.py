"""The MCAP project's conformance layouts, written by a port of its own generator.

The ``mcap`` repository (github.com/foxglove/mcap) publishes, under
``tests/conformance/data/<Input>/<Input>-<features>.mcap``, 416 small files: six inputs
(:data:`INPUTS`) written in every sensible combination of writer features (:data:`VARIANTS`).
They are the deterministic output of ``tests/conformance/scripts/generate-inputs.ts``
(``generateFile``), with the variants of ``tests/conformance/variants/`` and the record layouts
of ``typescript/core/src/McapRecordBuilder.ts`` and ``ChunkBuilder.ts``. This module is a port
of that generator to Python, byte for byte: :func:`generate` reproduces every published file
(``mcap_conformance_sha256.json`` beside this module holds their sizes and SHA-256, taken from
the repository's Git LFS pointers).

:func:`write_layout` is the same writer opened up: any records (schemas, channels, messages,
attachments, metadata) in any feature combination, optionally in several chunks
(``messages_per_chunk``, ``chunk_bytes``, or an explicit :class:`ChunkBreak` in the records),
compressed (``zstd``, ``lz4``) and with damaged footers (``summary_start_past_end``,
``summary_offset_start_past_end``, ``bad_summary_crc``). Records are written in the order
given, so a hostile layout is a matter of ordering: a channel after the messages that use it,
a message on a channel never declared, a channel or schema id declared twice.

Features (the generator's codes)
--------------------------------
``ch`` chunks, ``mx`` message indexes, ``st`` statistics, ``rsh`` repeated schemas (summary),
``rch`` repeated channels (summary), ``ax`` attachment indexes, ``mdx`` metadata indexes,
``chx`` chunk indexes, ``sum`` summary offsets, ``pad`` three extra bytes (``01 ff ff``) at the
end of every record outside chunks except Message, Chunk, DataEnd and Footer.

Example
-------
>>> from tests.support.mcap_conformance import VARIANTS, generate, variant_name
>>> len(VARIANTS)
416
>>> name, features = VARIANTS[0]
>>> variant_name(name, features), len(generate(name, features))
('NoData', 75)
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import BinaryIO

__all__ = [
    "FEATURES",
    "INPUTS",
    "VARIANTS",
    "Attachment",
    "Channel",
    "ChunkBreak",
    "Message",
    "Metadata",
    "Record",
    "Schema",
    "generate",
    "read_records",
    "variant_name",
    "write_layout",
]

MAGIC = b"\x89MCAP0\r\n"
PAD = b"\x01\xff\xff"

OP_HEADER = 0x01
OP_FOOTER = 0x02
OP_SCHEMA = 0x03
OP_CHANNEL = 0x04
OP_MESSAGE = 0x05
OP_CHUNK = 0x06
OP_MESSAGE_INDEX = 0x07
OP_CHUNK_INDEX = 0x08
OP_ATTACHMENT = 0x09
OP_ATTACHMENT_INDEX = 0x0A
OP_STATISTICS = 0x0B
OP_METADATA = 0x0C
OP_METADATA_INDEX = 0x0D
OP_SUMMARY_OFFSET = 0x0E
OP_DATA_END = 0x0F

#: The generator's features, in the order of ``TestFeatures`` (types.ts), which fixes the
#: order in which :data:`VARIANTS` enumerates their combinations.
FEATURES: tuple[str, ...] = ("ch", "mx", "st", "rsh", "rch", "ax", "mdx", "chx", "sum", "pad")


@dataclass(frozen=True)
class Schema:
    """A Schema record (id 1..65535)."""

    id: int
    name: str
    encoding: str
    data: bytes


@dataclass(frozen=True)
class Channel:
    """A Channel record (``schema_id`` 0: schemaless); ``metadata`` as (key, value) pairs."""

    id: int
    topic: str
    schema_id: int
    message_encoding: str
    metadata: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Message:
    """A Message record."""

    channel_id: int
    sequence: int
    log_time: int
    publish_time: int
    data: bytes


@dataclass(frozen=True)
class Attachment:
    """An Attachment record (always written outside chunks)."""

    name: str
    media_type: str
    log_time: int
    create_time: int
    data: bytes


@dataclass(frozen=True)
class Metadata:
    """A Metadata record (always written outside chunks)."""

    name: str
    metadata: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class ChunkBreak:
    """Not a record: closes the open chunk (if it holds anything), so that the next record
    starts a new one. Ignored without the ``ch`` feature."""


Record = Schema | Channel | Message | Attachment | Metadata | ChunkBreak


def _ten_messages() -> list[Record]:
    times = [0, 2, 1, 3, 3, 5, 4, 7, 8, 9]
    return [Message(1, seq, t, t, b"\x01\x02\x03") for seq, t in enumerate(times)]


_EXAMPLE_SCHEMA = Schema(1, "Example", "c", b"\x04\x05\x06")
_EXAMPLE_CHANNEL = Channel(1, "example", 1, "a", (("foo", "bar"),))

#: The six inputs of ``tests/conformance/variants/inputs.ts``, in its order.
INPUTS: dict[str, list[Record]] = {
    "NoData": [],
    "OneSchemalessMessage": [
        Channel(1, "example", 0, "text"),
        Message(1, 10, 2, 1, b"\x01\x02\x03"),
    ],
    "OneMessage": [_EXAMPLE_SCHEMA, _EXAMPLE_CHANNEL, Message(1, 10, 2, 1, b"\x01\x02\x03")],
    "OneAttachment": [Attachment("myFile", "application/octet-stream", 2, 1, b"\x01\x02\x03")],
    "OneMetadata": [Metadata("myMetadata", (("foo", "bar"),))],
    "TenMessages": [_EXAMPLE_SCHEMA, _EXAMPLE_CHANNEL, *_ten_messages()],
}


def _combinations(features: Sequence[str]) -> Iterator[frozenset[str]]:
    """Every subset of ``features``, in the order of ``generateFeatureCombinations``."""
    if not features:
        yield frozenset()
        return
    for rest in _combinations(features[1:]):
        yield rest
        yield rest | {features[0]}


def _valid(records: Sequence[Record], f: frozenset[str]) -> bool:
    """The combination rules of ``generateTestVariants.ts``."""
    kinds = {type(r) for r in records}
    if "ax" in f and Attachment not in kinds:
        return False
    if "mdx" in f and Metadata not in kinds:
        return False
    if "rsh" in f and Schema not in kinds:
        return False
    if "rch" in f and Channel not in kinds:
        return False
    if not kinds & {Message, Channel, Schema} and f & {"ch", "chx", "mx"}:
        return False
    if "sum" in f and not f & {"chx", "rsh", "rch", "mdx", "ax", "st"}:
        return False
    return not (f & {"chx", "mx"} and "ch" not in f)


def variants_of(records: Sequence[Record]) -> list[frozenset[str]]:
    """The feature sets the generator would write ``records`` in (its combination rules)."""
    return [f for f in _combinations(FEATURES) if _valid(records, f)]


def variant_name(input_name: str, features: Iterable[str]) -> str:
    """The published file name without ``.mcap``: the input, then the features sorted."""
    return "-".join([input_name, *sorted(features)])


#: (input name, feature set) for every published file, in the generator's order (416).
VARIANTS: list[tuple[str, frozenset[str]]] = [
    (name, f) for name, records in INPUTS.items() for f in variants_of(records)
]


# --- Record encoding (McapRecordBuilder.ts) -------------------------------------------------


def _str(s: str) -> bytes:
    b = s.encode()
    return struct.pack("<I", len(b)) + b


def _map(pairs: Iterable[tuple[str, str]]) -> bytes:
    body = b"".join(_str(k) + _str(v) for k, v in pairs)
    return struct.pack("<I", len(body)) + body


def _record(op: int, body: bytes, pad: bool = False) -> bytes:
    if pad:
        body += PAD
    return struct.pack("<BQ", op, len(body)) + body


def _schema(s: Schema, pad: bool) -> bytes:
    body = (
        struct.pack("<H", s.id)
        + _str(s.name)
        + _str(s.encoding)
        + struct.pack("<I", len(s.data))
        + s.data
    )
    return _record(OP_SCHEMA, body, pad)


def _channel(c: Channel, pad: bool) -> bytes:
    body = (
        struct.pack("<HH", c.id, c.schema_id)
        + _str(c.topic)
        + _str(c.message_encoding)
        + _map(c.metadata)
    )
    return _record(OP_CHANNEL, body, pad)


def _message(m: Message) -> bytes:
    head = struct.pack("<HIQQ", m.channel_id, m.sequence, m.log_time, m.publish_time)
    return _record(OP_MESSAGE, head + m.data)


def _attachment(a: Attachment, pad: bool) -> bytes:
    body = (
        struct.pack("<QQ", a.log_time, a.create_time)
        + _str(a.name)
        + _str(a.media_type)
        + struct.pack("<Q", len(a.data))
        + a.data
    )
    body += struct.pack("<I", zlib.crc32(body))
    return _record(OP_ATTACHMENT, body, pad)


def _metadata(m: Metadata, pad: bool) -> bytes:
    return _record(OP_METADATA, _str(m.name) + _map(m.metadata), pad)


def _compress(data: bytes, compression: str) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        import zstandard

        return zstandard.ZstdCompressor().compress(data)
    if compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        out: bytes = lz4.frame.compress(data)
        return out
    raise ValueError(f"chunk compression {compression!r}: expected '', 'zstd' or 'lz4'")


@dataclass
class _Chunk:
    """ChunkBuilder.ts: the records of one chunk (never padded) and its message indexes."""

    message_index: bool
    buffer: bytearray = field(default_factory=bytearray)
    messages: int = 0
    start: int = 0
    end: int = 0
    indices: dict[int, list[tuple[int, int]]] = field(default_factory=dict)

    def add(self, r: Schema | Channel | Message) -> None:
        if isinstance(r, Schema):
            self.buffer += _schema(r, False)
        elif isinstance(r, Channel):
            if self.message_index:
                self.indices.setdefault(r.id, [])
            self.buffer += _channel(r, False)
        else:
            if self.messages == 0 or r.log_time < self.start:
                self.start = r.log_time
            if self.messages == 0 or r.log_time > self.end:
                self.end = r.log_time
            if self.message_index:
                self.indices.setdefault(r.channel_id, []).append((r.log_time, len(self.buffer)))
            self.messages += 1
            self.buffer += _message(r)


@dataclass
class _ChunkIndex:
    start: int
    end: int
    offset: int
    length: int
    index_offsets: list[tuple[int, int]]
    index_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int


def write_layout(
    records: Sequence[Record],
    features: Iterable[str],
    *,
    messages_per_chunk: int | None = None,
    chunk_bytes: int | None = None,
    compression: str = "",
    profile: str = "",
    library: str = "",
    summary_start_past_end: bool = False,
    summary_offset_start_past_end: bool = False,
    bad_summary_crc: bool = False,
) -> bytes:
    """An MCAP file holding ``records``, in their order, written as ``generateFile`` does.

    With the defaults this is the conformance generator exactly: all schemas, channels and
    messages in one uncompressed chunk (with ``ch``), attachments and metadata in the data
    section where they come (before that chunk, which is written last).

    Parameters
    ----------
    records
        Schemas, channels, messages, attachments and metadata, in file order; a
        :class:`ChunkBreak` closes the open chunk. Nothing is checked: a message may name a
        channel never declared, an id may be declared twice.
    features
        Feature codes (see the module docstring); unknown codes raise ``ValueError``.
    messages_per_chunk, chunk_bytes
        With ``ch``: close a chunk once it holds this many messages, or once its uncompressed
        records reach this many bytes (checked after each message). None: one chunk.
    compression
        Chunk compression: ``""`` (the generator's), ``"zstd"`` or ``"lz4"`` (needs the
        ``zstandard`` or ``lz4`` module).
    profile, library
        The Header record's fields (the generator's are empty).
    summary_start_past_end, summary_offset_start_past_end
        Damage: the Footer's ``summary_start`` (or ``summary_offset_start``) points 4096 bytes
        past the end of the file (the summary CRC is computed over the fields as written).
    bad_summary_crc
        Damage: the Footer's summary CRC is wrong (never 0, which means "not computed").

    Returns
    -------
    bytes
        The whole file.
    """
    f = frozenset(features)
    unknown = f - set(FEATURES)
    if unknown:
        raise ValueError(f"unknown features {sorted(unknown)}; known: {list(FEATURES)}")
    pad = "pad" in f
    out = bytearray(MAGIC)
    out += _record(OP_HEADER, _str(profile) + _str(library), pad)

    chunk = _Chunk("mx" in f) if "ch" in f else None
    chunk_count = 0
    chunk_indexes: list[_ChunkIndex] = []
    metadata_indexes: list[tuple[int, int, str]] = []
    attachment_indexes: list[tuple[int, int, Attachment]] = []
    counts = {"schema": 0, "channel": 0, "message": 0, "attachment": 0, "metadata": 0}
    start: int | None = None
    end: int | None = None
    per_channel: dict[int, int] = {}

    def flush() -> None:
        nonlocal chunk, chunk_count
        if chunk is None:
            return
        raw = bytes(chunk.buffer)
        stored = _compress(raw, compression)
        offset = len(out)
        body = struct.pack("<QQQI", chunk.start, chunk.end, len(raw), zlib.crc32(raw))
        body += _str(compression) + struct.pack("<Q", len(stored)) + stored
        out.extend(_record(OP_CHUNK, body))
        length = len(out) - offset
        index_offsets: list[tuple[int, int]] = []
        index_length = 0
        for channel_id, entries in chunk.indices.items():
            index_offsets.append((channel_id, len(out)))
            tuples = b"".join(struct.pack("<QQ", t, o) for t, o in entries)
            rec = _record(
                OP_MESSAGE_INDEX, struct.pack("<HI", channel_id, len(tuples)) + tuples, pad
            )
            out.extend(rec)
            index_length += len(rec)
        if "chx" in f:
            chunk_indexes.append(
                _ChunkIndex(
                    chunk.start,
                    chunk.end,
                    offset,
                    length,
                    index_offsets,
                    index_length,
                    compression,
                    len(stored),
                    len(raw),
                )
            )
        chunk_count += 1
        chunk = _Chunk("mx" in f)

    for r in records:
        if isinstance(r, ChunkBreak):
            if chunk is not None and chunk.buffer:
                flush()
            continue
        if isinstance(r, Attachment):
            counts["attachment"] += 1
            rec = _attachment(r, pad)
            if "ax" in f:
                attachment_indexes.append((len(out), len(rec), r))
            out += rec
            continue
        if isinstance(r, Metadata):
            counts["metadata"] += 1
            rec = _metadata(r, pad)
            if "mdx" in f:
                metadata_indexes.append((len(out), len(rec), r.name))
            out += rec
            continue
        if isinstance(r, Schema):
            counts["schema"] += 1
        elif isinstance(r, Channel):
            counts["channel"] += 1
        else:
            counts["message"] += 1
            per_channel[r.channel_id] = per_channel.get(r.channel_id, 0) + 1
            start = r.log_time if start is None else min(start, r.log_time)
            end = r.log_time if end is None else max(end, r.log_time)
        if chunk is None:
            if isinstance(r, Schema):
                out += _schema(r, pad)
            elif isinstance(r, Channel):
                out += _channel(r, pad)
            else:
                out += _message(r)
            continue
        chunk.add(r)
        if isinstance(r, Message) and (
            (messages_per_chunk is not None and chunk.messages >= messages_per_chunk)
            or (chunk_bytes is not None and len(chunk.buffer) >= chunk_bytes)
        ):
            flush()
    if chunk is not None and (chunk.buffer or chunk_count == 0):
        flush()

    out += struct.pack("<BQI", OP_DATA_END, 4, zlib.crc32(out))
    summary_start = len(out)

    def group(write: Callable[[], None]) -> tuple[int, int]:
        at = len(out)
        write()
        return at, len(out) - at

    def repeated_schemas() -> None:
        if "rsh" in f:
            for r in records:
                if isinstance(r, Schema):
                    out.extend(_schema(r, pad))

    def repeated_channels() -> None:
        if "rch" in f:
            for r in records:
                if isinstance(r, Channel):
                    out.extend(_channel(r, pad))

    def statistics() -> None:
        if "st" in f:
            body = struct.pack(
                "<QHIIIIQQ",
                counts["message"],
                counts["schema"],
                counts["channel"],
                counts["attachment"],
                counts["metadata"],
                chunk_count,
                start or 0,
                end or 0,
            )
            pairs = b"".join(struct.pack("<HQ", k, v) for k, v in per_channel.items())
            body += struct.pack("<I", len(pairs)) + pairs
            out.extend(_record(OP_STATISTICS, body, pad))

    def metadata_index() -> None:
        for offset, length, name in metadata_indexes:
            out.extend(
                _record(OP_METADATA_INDEX, struct.pack("<QQ", offset, length) + _str(name), pad)
            )

    def attachment_index() -> None:
        for offset, length, a in attachment_indexes:
            body = struct.pack("<QQQQQ", offset, length, a.log_time, a.create_time, len(a.data))
            out.extend(_record(OP_ATTACHMENT_INDEX, body + _str(a.name) + _str(a.media_type), pad))

    def chunk_index() -> None:
        for c in chunk_indexes:
            body = struct.pack(
                "<QQQQI", c.start, c.end, c.offset, c.length, 10 * len(c.index_offsets)
            )
            body += b"".join(struct.pack("<HQ", k, v) for k, v in c.index_offsets)
            body += struct.pack("<Q", c.index_length) + _str(c.compression)
            body += struct.pack("<QQ", c.compressed_size, c.uncompressed_size)
            out.extend(_record(OP_CHUNK_INDEX, body, pad))

    groups = [
        (OP_SCHEMA, group(repeated_schemas)),
        (OP_CHANNEL, group(repeated_channels)),
        (OP_STATISTICS, group(statistics)),
        (OP_METADATA_INDEX, group(metadata_index)),
        (OP_ATTACHMENT_INDEX, group(attachment_index)),
        (OP_CHUNK_INDEX, group(chunk_index)),
    ]
    has_summary = len(out) != summary_start

    summary_offset_start = 0
    if "sum" in f:
        summary_offset_start = len(out)
        for op, (at, length) in groups:
            if length:
                out += _record(OP_SUMMARY_OFFSET, struct.pack("<BQQ", op, at, length), pad)

    file_end = len(out) + 9 + 20 + len(MAGIC)
    footer_start = summary_start if has_summary else 0
    if summary_start_past_end:
        footer_start = file_end + 4096
    if summary_offset_start_past_end:
        summary_offset_start = file_end + 4096
    prefix = struct.pack("<BQQQ", OP_FOOTER, 20, footer_start, summary_offset_start)
    crc = zlib.crc32(prefix, zlib.crc32(bytes(out[summary_start:])))
    if bad_summary_crc:
        crc = crc ^ 1 or 2
    out += prefix + struct.pack("<I", crc)
    out += MAGIC
    return bytes(out)


def generate(input_name: str, features: Iterable[str]) -> bytes:
    """The published conformance file of one input (a key of :data:`INPUTS`) and features."""
    return write_layout(INPUTS[input_name], features)


def read_records(stream: BinaryIO) -> tuple[str, list[Record]]:
    """The profile and the records of an MCAP file, read by the ``mcap`` package's reader.

    Each schema and channel comes once, just before the first message that uses it; then the
    messages in file order, then the attachments and the metadata. Enough to write a
    recording's content again with :func:`write_layout`.
    """
    from mcap.reader import make_reader

    reader = make_reader(stream)
    profile = reader.get_header().profile
    out: list[Record] = []
    schemas: set[int] = set()
    channels: set[int] = set()
    for schema, channel, m in reader.iter_messages(log_time_order=False):
        if schema is not None and schema.id not in schemas:
            schemas.add(schema.id)
            out.append(Schema(schema.id, schema.name, schema.encoding, bytes(schema.data)))
        if channel.id not in channels:
            channels.add(channel.id)
            meta = tuple(channel.metadata.items())
            out.append(
                Channel(
                    channel.id, channel.topic, channel.schema_id, channel.message_encoding, meta
                )
            )
        out.append(Message(m.channel_id, m.sequence, m.log_time, m.publish_time, bytes(m.data)))
    for a in reader.iter_attachments():
        out.append(Attachment(a.name, a.media_type, a.log_time, a.create_time, bytes(a.data)))
    for md in reader.iter_metadata():
        out.append(Metadata(md.name, tuple(md.metadata.items())))
    return profile, out
