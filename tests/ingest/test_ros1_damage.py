"""ROS 1 bags cut short or damaged: what is read is exactly what the file still holds.

The bags are written by ``rosbags-convert`` (:func:`tests.support.bags.write_ros1`: chunks
uncompressed, bz2 or lz4) from the messages of :mod:`tests.ingest.test_bags`. The truth of
each cut comes from outside thermrs: which message is in which chunk and where in its data
(the bag's index, read by ``rosbags``), and how far the bytes before the cut decompress
(Python's own ``bz2`` and ``lz4.frame``); a message is kept when its record ends within that.
The kept messages are written as one MCAP file by the ``mcap`` package, and the cut bag must
give that file's tables, identical, with one ``truncated`` loss naming the cut's byte range.
A recorder killed before closing the bag (its header's ``index_pos`` still 0, written by
``rosbags``' own ROS 1 writer left open) is read the same way. A damaged chunk is skipped
and reported with the messages its index records say it held; the chunks after it are read.
"""

from __future__ import annotations

import bz2
import struct
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import lz4.frame  # type: ignore[import-untyped]
import pytest
import thermrs
from polars.testing import assert_frame_equal
from rosbags.rosbag1 import Reader

from tests.ingest.test_bags import TABLES, _messages, _run_cli
from tests.support.bags import LOG_DELAY_NS, Message, write_mcap, write_ros1


@dataclass(frozen=True)
class Chunk:
    """A chunk of the bag: its record's offset, its data's offset and length, its size
    uncompressed, its compression, and its messages (offset in the data, topic, time)."""

    pos: int
    data_at: int
    data_len: int
    size: int
    compression: str
    messages: list[tuple[int, str, int]]

    @property
    def end(self) -> int:
        return self.data_at + self.data_len


def _fields(b: bytes) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    i = 0
    while i < len(b):
        (n,) = struct.unpack_from("<I", b, i)
        name, _, value = b[i + 4 : i + 4 + n].partition(b"=")
        out[name.decode()] = value
        i += 4 + n
    return out


def _chunks(bag: Path) -> list[Chunk]:
    """The bag's chunks, from its index as ``rosbags`` reads it."""
    raw = bag.read_bytes()
    per: dict[int, list[tuple[int, str, int]]] = {}
    with Reader(bag) as r:
        topic = {c.id: c.topic for c in r.connections}
        for cid, entries in r.indexes.items():
            for e in entries:
                per.setdefault(e.chunk_pos, []).append((e.offset, topic[cid], e.time))
    out = []
    for pos in sorted(per):
        (hlen,) = struct.unpack_from("<I", raw, pos)
        f = _fields(raw[pos + 4 : pos + 4 + hlen])
        (dlen,) = struct.unpack_from("<I", raw, pos + 4 + hlen)
        (size,) = struct.unpack("<I", f["size"])
        out.append(
            Chunk(pos, pos + 8 + hlen, dlen, size, f["compression"].decode(), sorted(per[pos]))
        )
    return out


DECOMPRESS: dict[str, Callable[[bytes], bytes]] = {
    "none": lambda b: b,
    "bz2": lambda b: bz2.BZ2Decompressor().decompress(b),
    "lz4": lambda b: lz4.frame.LZ4FrameDecompressor().decompress(b),
}


def _kept(chunks: list[Chunk], raw: bytes, cut: int) -> Counter[tuple[str, int]]:
    """(topic, time) of every message whose record the first ``cut`` bytes hold whole."""
    kept: Counter[tuple[str, int]] = Counter()
    for c in chunks:
        if c.end <= cut:
            n = len(c.messages)
        elif c.data_at < cut:
            got = len(DECOMPRESS[c.compression](raw[c.data_at : cut]))
            ends = [m[0] for m in c.messages[1:]] + [c.size]
            n = sum(e <= got for e in ends)
        else:
            n = 0
        kept.update((t, ts) for _, t, ts in c.messages[:n])
    return kept


def _select(messages: list[Message], kept: Counter[tuple[str, int]]) -> list[Message]:
    """The writer's messages the bag's kept records are (by topic and stamp)."""
    need = Counter(kept)
    out = []
    for m in messages:
        key = (m[0], m[2] + LOG_DELAY_NS)
        if need[key] > 0:
            need[key] -= 1
            out.append(m)
    assert not +need, "a kept record is none of the writer's messages"
    return out


@dataclass(frozen=True)
class World:
    messages: list[Message]
    dir: Path


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    msgs, _, _ = _messages(thermrs.load_rig())
    return World(msgs, tmp_path_factory.mktemp("ros1-damage"))


def _bag(world: World, compression: str) -> Path:
    bag = world.dir / f"full-{compression}.bag"
    if not bag.exists():
        write_ros1(world.messages, bag, compression=compression)
    return bag


def _assert_tables_of(ex: thermrs.Extraction, ref: thermrs.Extraction) -> None:
    for t in TABLES:
        assert_frame_equal(getattr(ex, t), getattr(ref, t), check_exact=True)
    assert ex.report.messages == ref.report.messages


@pytest.mark.parametrize("compression", ["none", "bz2", "lz4"])
def test_a_bag_cut_short_gives_every_message_before_the_cut(
    world: World, paper_rig: thermrs.Rig, compression: str
) -> None:
    full = _bag(world, compression)
    raw = full.read_bytes()
    chunks = _chunks(full)
    assert len(chunks) >= 4
    mid = chunks[len(chunks) // 2]
    late = chunks[-2]
    cuts = {
        "between chunks": mid.pos,
        "inside a chunk's data": mid.data_at + mid.data_len // 2,
        "inside a chunk's header": mid.pos + 9,
        "late in a chunk's data": late.data_at + late.data_len - 100,
        "inside the index records after a chunk": mid.end + 6,
    }
    for what, cut in cuts.items():
        bag = world.dir / f"cut-{compression}-{cut}.bag"
        bag.write_bytes(raw[:cut])
        kept = _kept(chunks, raw, cut)
        assert 0 < sum(kept.values()) < len(world.messages)
        ref = thermrs.extract(
            write_mcap(_select(world.messages, kept), world.dir / f"ref-{cut}.mcap"), paper_rig
        )
        ex = thermrs.extract(bag, paper_rig)
        _assert_tables_of(ex, ref)
        (loss,) = ex.report.losses
        assert loss["kind"] == "truncated", what
        # The lost range runs to the end of the file, from the record the cut is in.
        assert loss["offset"] + loss["bytes"] == cut, what
        starts = [c.pos for c in chunks] + [c.end for c in chunks]
        assert loss["offset"] <= cut and (loss["offset"] in starts or loss["bytes"] == 0), what
        # info reads the same bag without its index: the same messages.
        inv = thermrs.inventory.inventory(bag, rig=paper_rig)
        assert inv.messages == sum(kept.values()), what
        assert inv.losses, what


def test_a_recorder_killed_before_closing_the_bag(
    world: World, paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    """The bag as a killed recorder leaves it: its header still says it has no index
    (``index_pos`` 0, as ``rosbags``' writer writes it on opening), its complete chunks and
    their index records after it, nothing more."""
    from rosbags.rosbag1 import Writer

    full = _bag(world, "lz4")
    raw = full.read_bytes()
    chunks = _chunks(full)
    opened = tmp_path / "opened.bag"
    w = Writer(opened)
    w.open()
    assert w.bio is not None
    w.bio.flush()
    head = opened.read_bytes()
    w.bio.close()
    assert head[:13] == raw[:13] and len(head) == chunks[0].pos
    cut = chunks[3].pos
    bag = tmp_path / "killed.bag"
    bag.write_bytes(head + raw[len(head) : cut])
    kept = _kept(chunks, raw, cut)
    ref = thermrs.extract(
        write_mcap(_select(world.messages, kept), tmp_path / "ref.mcap"), paper_rig
    )
    ex = thermrs.extract(bag, paper_rig)
    _assert_tables_of(ex, ref)
    (loss,) = ex.report.losses
    assert (loss["kind"], loss["offset"], loss["bytes"]) == ("truncated", cut, 0)
    inv = thermrs.inventory.inventory(bag, rig=paper_rig)
    assert inv.messages == sum(kept.values()) and inv.chunks == 3
    r = _run_cli(
        "extract", str(bag), "--rig", str(paper_rig.source), "-o", str(tmp_path / "o.parquet")
    )
    assert r.returncode == 3 and "Traceback" not in r.stderr, r.stderr


@pytest.mark.parametrize("compression", ["bz2", "lz4"])
def test_a_damaged_chunk_is_skipped_and_reported(
    world: World, paper_rig: thermrs.Rig, compression: str, tmp_path: Path
) -> None:
    full = _bag(world, compression)
    raw = bytearray(full.read_bytes())
    chunks = _chunks(full)
    bad = chunks[len(chunks) // 2]
    # Its compressed data overwritten from the start: the stream's own header is gone.
    raw[bad.data_at : bad.data_at + 64] = b"\xa5" * 64
    bag = tmp_path / "damaged.bag"
    bag.write_bytes(bytes(raw))
    kept: Counter[tuple[str, int]] = Counter()
    for c in chunks:
        if c is not bad:
            kept.update((t, ts) for _, t, ts in c.messages)
    ref = thermrs.extract(
        write_mcap(_select(world.messages, kept), tmp_path / "ref.mcap"), paper_rig
    )
    ex = thermrs.extract(bag, paper_rig)
    _assert_tables_of(ex, ref)
    (loss,) = ex.report.losses
    assert (loss["kind"], loss["offset"], loss["bytes"]) == (
        "corrupt_chunk",
        bad.pos,
        bad.end - bad.pos,
    )
    assert loss["messages_lost"] == dict(Counter(t for _, t, _ in bad.messages))


@pytest.mark.parametrize("where", ["chunk header", "record in a chunk"])
def test_damage_in_an_uncompressed_bag_loses_only_itself(
    world: World, paper_rig: thermrs.Rig, where: str, tmp_path: Path
) -> None:
    """A chunk whose header length is garbage is skipped to the next intact record (found by
    scanning); a record inside a chunk whose length is garbage loses that chunk's records
    from it on, those before it are read."""
    full = _bag(world, "none")
    raw = bytearray(full.read_bytes())
    chunks = _chunks(full)
    bad = chunks[len(chunks) // 2]
    kept: Counter[tuple[str, int]] = Counter()
    for c in chunks:
        if c is not bad:
            kept.update((t, ts) for _, t, ts in c.messages)
    if where == "chunk header":
        raw[bad.pos : bad.pos + 4] = b"\xff\xff\xff\xff"
        want = ("corrupt_record", bad.pos, bad.end - bad.pos)
    else:
        k = len(bad.messages) // 2
        raw[bad.data_at + bad.messages[k][0] : bad.data_at + bad.messages[k][0] + 4] = b"\xff" * 4
        kept.update((t, ts) for _, t, ts in bad.messages[:k])
        want = ("corrupt_chunk", bad.pos, bad.end - bad.pos)
    bag = tmp_path / "damaged.bag"
    bag.write_bytes(bytes(raw))
    ref = thermrs.extract(
        write_mcap(_select(world.messages, kept), tmp_path / "ref.mcap"), paper_rig
    )
    ex = thermrs.extract(bag, paper_rig)
    _assert_tables_of(ex, ref)
    (loss,) = ex.report.losses
    assert (loss["kind"], loss["offset"], loss["bytes"]) == want


def test_a_bag_cut_inside_its_index_section_keeps_every_message(
    world: World, paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    full = _bag(world, "bz2")
    raw = full.read_bytes()
    (hlen,) = struct.unpack_from("<I", raw, 13)
    (index_pos,) = struct.unpack("<Q", _fields(raw[17 : 17 + hlen])["index_pos"])
    assert index_pos == _chunks(full)[-1].end or index_pos > _chunks(full)[-1].end
    cut = index_pos + (len(raw) - index_pos) // 2
    bag = tmp_path / "cut-index.bag"
    bag.write_bytes(raw[:cut])
    ex = thermrs.extract(bag, paper_rig)
    _assert_tables_of(ex, thermrs.extract(full, paper_rig))
    (loss,) = ex.report.losses
    assert loss["kind"] == "truncated" and loss["offset"] + loss["bytes"] == cut
    assert loss["offset"] >= index_pos
    inv = thermrs.inventory.inventory(bag, rig=paper_rig)
    assert inv.messages == len(world.messages)
