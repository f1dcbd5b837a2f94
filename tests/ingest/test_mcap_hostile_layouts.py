"""Layouts no conforming writer produces, but a dying, buggy or concatenating one does: a
channel declared after the messages that use it, a message on a channel never declared (alone,
and in the middle of a chunk), a channel id declared twice, a schema id redefined mid-file, a
footer whose summary offsets point past the end or whose summary CRC is wrong.

Written by :func:`tests.support.mcap_conformance.write_layout` from a simulated recording of
the paper rig. The requirement (issue: "0 frames lost on any valid file") is that thermrs'
extraction keeps every intact frame: the frames table equals that of the same messages in a
clean layout, every message is counted on its topic, a message on a channel never declared is
a loss naming the channel id (it cannot be read: its topic is unknown) and nothing else is.
A message belongs to the channel declared under its id most recently before it in the file, as
the ``mcap`` package's streamed reader reads them; a channel declared only after its messages is
still that channel (the file names no other).

Each layout also states what the ``mcap`` package's own readers yield (its streamed reader,
``NonSeekingReader``; its indexed reader, ``make_reader(f, validate_crcs=False)`` on a file),
checked by :func:`test_what_the_mcap_package_reads`: where they raise, thermrs is the only
reader that gets the frames out.
"""

from __future__ import annotations

import dataclasses
import io
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import thermrs
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Chunk
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader, breakup_chunk
from polars.testing import assert_frame_equal

from tests.ingest.test_extract import scenario
from tests.support.mcap_conformance import (
    Channel,
    ChunkBreak,
    Message,
    Record,
    Schema,
    read_records,
    write_layout,
)
from tests.support.recordings import ENCODERS, MSGDEFS, png_bytes, write_messages

#: Every summary feature, chunked (the richest layout a writer that finishes produces).
FULL = frozenset({"ch", "mx", "chx", "st", "rch", "rsh", "sum"})
#: Chunked, no summary (a writer that died after its last chunk).
CHUNKED = frozenset({"ch", "mx"})
UNCHUNKED: frozenset[str] = frozenset()
#: The channel id no record declares.
GHOST = 99


@dataclass(frozen=True)
class Base:
    """The clean recording: its records (schemas and channels before first use), its messages
    in file order, and for each message the ROS message it encodes."""

    profile: str
    records: list[Record]
    messages: list[Message]
    sources: list[tuple[str, str, int, dict[str, object]]]
    channel: dict[str, Channel]  # topic -> channel
    schema: dict[str, Schema]  # name -> schema


@dataclass(frozen=True)
class Layout:
    """A hostile file, what the mcap package makes of it, and where its unknown message is."""

    records: list[Record]
    features: frozenset[str]
    options: dict[str, Any] = field(default_factory=dict)
    #: What the streamed and the indexed reader yield: "as written" (every message on the topic
    #: the layout means), "misnamed" (every message, some on another topic), or the exception.
    streamed: str = "as written"
    indexed: str = "as written"
    #: Whether one message names channel GHOST.
    ghost: bool = False

    def data(self, base: Base) -> bytes:
        return write_layout(self.records, self.features, profile=base.profile, **self.options)


def make_base() -> Base:
    sc = scenario(thermrs.load_rig(), cycles=2)
    buf = io.BytesIO()
    write_messages(buf, sc.rec.messages, compression="none", chunked=False, summary=False)
    buf.seek(0)
    profile, records = read_records(buf)
    return Base(
        profile,
        records,
        [r for r in records if isinstance(r, Message)],
        list(sc.rec.messages),
        {r.topic: r for r in records if isinstance(r, Channel)},
        {r.name: r for r in records if isinstance(r, Schema)},
    )


CCD_A, CCD_B = "/ccd_a/image_raw", "/ccd_b/image_raw"


def at(records: list[Record], m: Message) -> int:
    """The position of message ``m`` in ``records``."""
    return next(i for i, r in enumerate(records) if r is m)


def late_channel(b: Base, before: int | None, *, chunk_break: bool) -> list[Record]:
    """Camera B's channel moved to just before message ``before`` (None: after the last
    message), in a chunk of its own start when ``chunk_break``."""
    rs = [r for r in b.records if r is not b.channel[CCD_B]]
    i = len(rs) if before is None else at(rs, b.messages[before])
    moved: list[Record] = [ChunkBreak(), b.channel[CCD_B]] if chunk_break else [b.channel[CCD_B]]
    return rs[:i] + moved + rs[i:]


def ghost_after(b: Base, k: int, *, chunk_break: bool = False) -> list[Record]:
    """A copy of camera A's first frame on channel GHOST, right after message ``k`` (and a
    chunk starting at message ``k`` when ``chunk_break``)."""
    first_a = next(m for m in b.messages if m.channel_id == b.channel[CCD_A].id)
    ghost = dataclasses.replace(first_a, channel_id=GHOST, sequence=10_000)
    i = at(b.records, b.messages[k])
    head = [*b.records[:i], ChunkBreak()] if chunk_break else b.records[:i]
    return [*head, b.records[i], ghost, *b.records[i + 1 :]]


def swapped_channels(b: Base, from_message: int) -> list[Record]:
    """From message ``from_message`` on, cameras A and B trade channel ids: both ids declared
    again there with the other's topic, and the messages after use the new ids."""
    a, bb = b.channel[CCD_A], b.channel[CCD_B]
    swap = {a.id: bb.id, bb.id: a.id}
    i = at(b.records, b.messages[from_message])
    after = [
        dataclasses.replace(r, channel_id=swap.get(r.channel_id, r.channel_id))
        if isinstance(r, Message)
        else r
        for r in b.records[i:]
    ]
    redeclared = [dataclasses.replace(a, topic=bb.topic), dataclasses.replace(bb, topic=a.topic)]
    return [*b.records[:i], *redeclared, *after]


def schema_text_changed(b: Base, from_message: int) -> list[Record]:
    """The Image schema id declared again at message ``from_message`` with another text (a
    comment, blank lines): same type, different content."""
    image = b.schema["sensor_msgs/msg/Image"]
    text = b"# declared again by a second writer\n" + image.data.replace(b"\n", b"\n\n")
    i = at(b.records, b.messages[from_message])
    return [*b.records[:i], dataclasses.replace(image, data=text), *b.records[i:]]


def schema_type_changed(b: Base, from_message: int) -> list[Record]:
    """The Image schema id becomes sensor_msgs/msg/CompressedImage at message
    ``from_message``: the CCD frames after it are the same pixels as lossless PNGs. The thermal
    camera has an Image schema of its own (a new id) from the start."""
    image = b.schema["sensor_msgs/msg/Image"]
    thermal_schema = Schema(
        max(b.schema[n].id for n in b.schema) + 1, image.name, image.encoding, image.data
    )
    thermal = b.channel["/thermal/image_raw"]
    rs: list[Record] = []
    for r in b.records:
        if r is thermal:
            rs += [thermal_schema, dataclasses.replace(thermal, schema_id=thermal_schema.id)]
        else:
            rs.append(r)
    compressed = "sensor_msgs/msg/CompressedImage"
    new = dataclasses.replace(image, name=compressed, data=MSGDEFS[compressed].encode())
    ccd = {b.channel[CCD_A].id, b.channel[CCD_B].id}
    i = at(rs, b.messages[from_message])
    after: list[Record] = [new]
    for r in rs[i:]:
        if isinstance(r, Message) and r.channel_id in ccd:
            msg = b.sources[r.sequence][3]
            assert msg["encoding"] == "mono8" and msg["step"] == msg["width"]
            h, w = int(msg["height"]), int(msg["width"])  # type: ignore[call-overload]
            img = np.frombuffer(msg["data"], np.uint8).reshape(h, w)  # type: ignore[call-overload]
            png = {"header": msg["header"], "format": "png", "data": png_bytes(img)}
            r = dataclasses.replace(r, data=ENCODERS[compressed](png))
        after.append(r)
    return rs[:i] + after


NO_CHANNEL = "McapError: no channel record found with id {}"

#: name -> how to build it from the clean recording. Messages per cycle: joint state, A, A,
#: B (dark), joint state, B, B, A (dark), thermal, ambient; two cycles.
LAYOUTS: dict[str, Callable[[Base], Layout]] = {
    # (a) A channel declared after messages that use it; no summary (the writer died).
    "late-channel-after-all-unchunked": lambda b: Layout(
        late_channel(b, None, chunk_break=False),
        UNCHUNKED,
        streamed=NO_CHANNEL.format(b.channel[CCD_B].id),
        indexed=NO_CHANNEL.format(b.channel[CCD_B].id),
    ),
    "late-channel-mid-file-unchunked": lambda b: Layout(
        late_channel(b, 10, chunk_break=False),
        UNCHUNKED,
        streamed=NO_CHANNEL.format(b.channel[CCD_B].id),
        indexed=NO_CHANNEL.format(b.channel[CCD_B].id),
    ),
    "late-channel-in-last-chunk": lambda b: Layout(
        late_channel(b, None, chunk_break=True),
        CHUNKED,
        {"messages_per_chunk": 4},
        streamed=NO_CHANNEL.format(b.channel[CCD_B].id),
        indexed=NO_CHANNEL.format(b.channel[CCD_B].id),
    ),
    "late-channel-in-later-chunk": lambda b: Layout(
        late_channel(b, 10, chunk_break=True),
        CHUNKED,
        {"messages_per_chunk": 4},
        streamed=NO_CHANNEL.format(b.channel[CCD_B].id),
        indexed=NO_CHANNEL.format(b.channel[CCD_B].id),
    ),
    "late-channel-in-later-chunk-zstd": lambda b: Layout(
        late_channel(b, 10, chunk_break=True),
        CHUNKED,
        {"messages_per_chunk": 4, "compression": "zstd"},
        streamed=NO_CHANNEL.format(b.channel[CCD_B].id),
        indexed=NO_CHANNEL.format(b.channel[CCD_B].id),
    ),
    "late-channel-mid-chunk": lambda b: Layout(
        # After camera B's first frames (messages 3 and 5), inside the chunk of messages 4-7.
        late_channel(b, 6, chunk_break=False),
        CHUNKED,
        {"messages_per_chunk": 4},
        streamed=NO_CHANNEL.format(b.channel[CCD_B].id),
        indexed=NO_CHANNEL.format(b.channel[CCD_B].id),
    ),
    # (b) A message on a channel id never declared.
    "undeclared-channel-unchunked": lambda b: Layout(
        ghost_after(b, 9),
        UNCHUNKED,
        streamed=NO_CHANNEL.format(GHOST),
        indexed=NO_CHANNEL.format(GHOST),
        ghost=True,
    ),
    "undeclared-channel-unchunked-summary": lambda b: Layout(
        ghost_after(b, 9),
        frozenset({"st", "rch", "rsh", "sum"}),
        streamed=NO_CHANNEL.format(GHOST),
        indexed=NO_CHANNEL.format(GHOST),
        ghost=True,
    ),
    # (f) ... in the middle of a chunk, camera frames after it in the same chunk: the chunk
    # holds message 4 (joint state), the unknown one, then 5 (B), 6 (B), 7 (A dark).
    "undeclared-channel-mid-chunk": lambda b: Layout(
        ghost_after(b, 4, chunk_break=True),
        CHUNKED,
        {"messages_per_chunk": 5},
        streamed=NO_CHANNEL.format(GHOST),
        indexed=NO_CHANNEL.format(GHOST),
        ghost=True,
    ),
    "undeclared-channel-mid-chunk-summary": lambda b: Layout(
        ghost_after(b, 4, chunk_break=True),
        FULL,
        {"messages_per_chunk": 5},
        streamed=NO_CHANNEL.format(GHOST),
        indexed=f"KeyError: {GHOST}",
        ghost=True,
    ),
    "undeclared-channel-mid-chunk-summary-zstd": lambda b: Layout(
        ghost_after(b, 4, chunk_break=True),
        FULL,
        {"messages_per_chunk": 5, "compression": "zstd"},
        streamed=NO_CHANNEL.format(GHOST),
        indexed=f"KeyError: {GHOST}",
        ghost=True,
    ),
    # ... and before the declarations of the cameras' channels in the first chunk: message 0
    # (joint state), the unknown one, the Image schema, channel A, 1 (A), 2 (A), channel B,
    # 3 (B).
    "undeclared-channel-before-declarations-in-chunk": lambda b: Layout(
        ghost_after(b, 0),
        CHUNKED,
        {"messages_per_chunk": 5},
        streamed=NO_CHANNEL.format(GHOST),
        indexed=NO_CHANNEL.format(GHOST),
        ghost=True,
    ),
    # (c) Channel ids declared twice with different topics (cameras A and B trade ids).
    "channel-ids-swapped-unchunked": lambda b: Layout(swapped_channels(b, 10), UNCHUNKED),
    "channel-ids-swapped-chunked": lambda b: Layout(
        swapped_channels(b, 10), CHUNKED, {"messages_per_chunk": 4}
    ),
    "channel-ids-swapped-chunked-summary": lambda b: Layout(
        # The summary repeats both declarations of each id: the indexed reader names every
        # message by the last one, so the first cycle's frames land on the other camera.
        swapped_channels(b, 10),
        FULL,
        {"messages_per_chunk": 4},
        indexed="misnamed",
    ),
    # (d) A schema id redefined mid-file.
    "schema-text-changed-unchunked": lambda b: Layout(schema_text_changed(b, 10), UNCHUNKED),
    "schema-text-changed-chunked-summary": lambda b: Layout(
        schema_text_changed(b, 10), FULL, {"messages_per_chunk": 4}
    ),
    "schema-type-changed-unchunked": lambda b: Layout(schema_type_changed(b, 10), UNCHUNKED),
    "schema-type-changed-chunked-summary": lambda b: Layout(
        schema_type_changed(b, 10), FULL, {"messages_per_chunk": 4}
    ),
    # (e) A damaged footer: the summary past the end of the file, or a wrong summary CRC.
    "summary-start-past-end": lambda b: Layout(
        b.records,
        FULL,
        {"messages_per_chunk": 4, "summary_start_past_end": True},
        indexed="EndOfFile: ",
    ),
    "summary-offset-start-past-end": lambda b: Layout(
        b.records, FULL, {"messages_per_chunk": 4, "summary_offset_start_past_end": True}
    ),
    "summary-crc-wrong": lambda b: Layout(
        b.records, FULL, {"messages_per_chunk": 4, "bad_summary_crc": True}
    ),
}


@dataclass(frozen=True)
class World:
    base: Base
    rig: thermrs.Rig
    clean: thermrs.Extraction
    #: (topic, publish time) of every message, as the layouts mean them.
    truth: Counter[tuple[str, int]]
    built: dict[str, tuple[Layout, bytes]] = field(default_factory=dict)

    def layout(self, name: str) -> tuple[Layout, bytes]:
        """The layout ``name`` and its file, built once for the three tests."""
        if name not in self.built:
            layout = LAYOUTS[name](self.base)
            self.built[name] = (layout, layout.data(self.base))
        return self.built[name]


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory, paper_rig: thermrs.Rig) -> World:
    base = make_base()
    path = tmp_path_factory.mktemp("hostile-layouts") / "clean.mcap"
    path.write_bytes(write_layout(base.records, FULL, messages_per_chunk=4, profile=base.profile))
    clean = thermrs.extract(path, paper_rig)
    topic = {c.id: c.topic for c in base.channel.values()}
    truth = Counter((topic[m.channel_id], m.publish_time) for m in base.messages)
    # The clean layout is read alike by thermrs and the mcap package.
    with path.open("rb") as fh:
        read = Counter((c.topic, m.publish_time) for _, c, m in make_reader(fh).iter_messages())
    assert read == truth
    assert Counter(clean.frames["camera"]) == {
        cam.name: sum(n for (t, _), n in truth.items() if t == cam.topic)
        for cam in paper_rig.cameras
    }
    assert not clean.report.skipped and not clean.report.losses
    return World(base, paper_rig, clean, truth)


def read_by(reader: Callable[[bytes], Any], data: bytes, truth: Counter[tuple[str, int]]) -> str:
    """What an mcap package reader yields: "as written", "misnamed", "lost N" or the
    exception."""
    try:
        got = Counter((c.topic, m.publish_time) for _, c, m in reader(data))
    except Exception as e:
        return f"{type(e).__name__}: {e}"
    if got == truth:
        return "as written"
    if got.total() == truth.total():
        return "misnamed"
    return f"lost {truth.total() - got.total()}"


def streamed(data: bytes) -> Any:
    return NonSeekingReader(io.BytesIO(data)).iter_messages(log_time_order=False)


def indexed(data: bytes) -> Any:
    return make_reader(io.BytesIO(data), validate_crcs=False).iter_messages(log_time_order=False)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_what_the_mcap_package_reads(world: World, name: str) -> None:
    layout, data = world.layout(name)
    truth = world.truth
    got = {"streamed": read_by(streamed, data, truth), "indexed": read_by(indexed, data, truth)}
    assert got == {"streamed": layout.streamed, "indexed": layout.indexed}


def after_ghost_in_its_chunk(data: bytes, base: Base) -> list[tuple[str, int]]:
    """(topic, publish time) of the CCD messages that follow the GHOST message inside its
    chunk (the mcap package's chunk reader)."""
    topic = {c.id: c.topic for c in base.channel.values()}
    for rec in StreamReader(io.BytesIO(data), emit_chunks=True).records:
        if not isinstance(rec, Chunk):
            continue
        inner = [r for r in breakup_chunk(rec) if isinstance(r, McapMessage)]
        ids = [m.channel_id for m in inner]
        if GHOST in ids:
            after = inner[ids.index(GHOST) + 1 :]
            return [
                (topic[m.channel_id], m.publish_time)
                for m in after
                if topic.get(m.channel_id) in (CCD_A, CCD_B)
            ]
    return []


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_extraction_keeps_every_intact_frame(tmp_path: Path, world: World, name: str) -> None:
    layout, data = world.layout(name)
    path = tmp_path / f"{name}.mcap"
    path.write_bytes(data)
    ex = thermrs.extract(path, world.rig)
    camera_topic = {c.name: c.topic for c in world.rig.cameras}
    frames = {
        (camera_topic[c], t) for c, t in zip(ex.frames["camera"], ex.frames["t_ns"], strict=True)
    }
    after_ghost = after_ghost_in_its_chunk(data, world.base)
    if layout.ghost and layout.features & {"ch"}:
        assert len(after_ghost) == 3  # the layout puts camera frames after it
    # A message on a channel the file never defines cannot be read (its topic is unknown):
    # the file is damaged there, so it is a loss (exit 3) naming the channel, and nothing else
    # of its chunk or the file is lost.
    got = {
        "frames per camera": dict(Counter(ex.frames["camera"])),
        "messages": ex.report.messages,
        "frames after the unknown message in its chunk": [f for f in after_ghost if f in frames],
        "skipped": sum(ex.report.skipped.values()),
        "losses": [(x["kind"], f"channel {GHOST}" in x["detail"]) for x in ex.report.losses],
        "lost": ex.report.lost_messages,
    }
    want = {
        "frames per camera": dict(Counter(world.clean.frames["camera"])),
        "messages": world.clean.report.messages,
        "frames after the unknown message in its chunk": after_ghost,
        "skipped": 0,
        "losses": [("undefined_channel", True)] if layout.ghost else [],
        "lost": {f"channel {GHOST}": 1} if layout.ghost else {},
    }
    assert got == want, ex.report.skipped_examples
    assert_frame_equal(ex.frames, world.clean.frames)
    assert_frame_equal(ex.temperatures, world.clean.temperatures)
    assert_frame_equal(ex.joints, world.clean.joints)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_inventory_counts_every_message_on_its_topic(
    tmp_path: Path, world: World, name: str
) -> None:
    path = tmp_path / f"{name}.mcap"
    path.write_bytes(world.layout(name)[1])
    inv = thermrs.inventory.inventory(path, rig=world.rig)
    got = {
        "topics": dict(zip(inv.topics["topic"], inv.topics["messages"], strict=True)),
        "losses": inv.losses,
    }
    layout = world.layout(name)[0]
    want = {
        "topics": dict(Counter(t for t, _ in world.truth.elements())),
        "losses": [f"1 message on channel {GHOST}, which the file never defines"]
        if layout.ghost
        else [],
    }
    assert got == want


@pytest.mark.parametrize(
    ("name", "says"),
    [
        ("summary-start-past-end", "summary section is unreadable"),
        ("summary-crc-wrong", "CRC-32"),
        ("schema-type-changed-chunked-summary", "defined twice"),
        ("channel-ids-swapped-unchunked", "defined twice"),
    ],
)
def test_a_damaged_summary_or_a_redefined_id_is_said(
    tmp_path: Path, world: World, name: str, says: str
) -> None:
    """Nothing is lost, so the exit stays 0, but the user is told how the file was read."""
    path = tmp_path / f"{name}.mcap"
    path.write_bytes(world.layout(name)[1])
    ex = thermrs.extract(path, world.rig)
    assert not ex.report.data_loss
    assert any(says in n for n in ex.report.notes), ex.report.notes
    if name.startswith("summary"):
        inv = thermrs.inventory.inventory(path, rig=world.rig)
        assert any(says in n for n in inv.notes), inv.notes
