"""A recording followed while it is written (``thermrs.follow``), checked against what an
independent writer put in it.

The writer is the ``mcap`` package (:func:`tests.support.recordings.write_messages`), with
chunks compressed by zstd or lz4, uncompressed, or no chunks at all. Its bytes reach the
followed file as a recorder's do: appended piece by piece, the pieces cut anywhere (inside a
chunk, inside a record header), and the follower steps between pieces. Every step must read
only the complete records added (each step starts where the last stopped, never before),
claim no loss for a record still being written, and the tables at the end must be those of
:func:`thermrs.extract` on the finished file; a recorder's own flushes (the writer writing
into the followed file, flushed after each message) likewise. A writer killed inside a chunk
leaves a file with no footer: every message of its complete chunks is there (the truth: the
chunk index of the same writer's finished file), nothing is claimed lost.
"""

from __future__ import annotations

import io
from pathlib import Path

import pytest
import thermrs
from mcap.reader import make_reader
from polars.testing import assert_frame_equal
from thermrs.follow import Follower, merge_reports

from tests.ingest.test_extract import scenario
from tests.support.recordings import write_messages

TABLES = ("frames", "visits", "temperatures", "joints", "runs")

#: (compression, chunked)
LAYOUTS = {"zstd": ("zstd", True), "lz4": ("lz4", True), "none": ("none", True),
           "unchunked": ("none", False)}  # fmt: skip


def _messages(rig: thermrs.Rig, cycles: int = 8) -> list[tuple[str, str, int, dict[str, object]]]:
    return sorted(scenario(rig, cycles=cycles, seed=4).rec.messages, key=lambda m: m[2])


def _bytes(rig: thermrs.Rig, layout: str) -> bytes:
    comp, chunked = LAYOUTS[layout]
    buf = io.BytesIO()
    write_messages(buf, _messages(rig), compression=comp, chunked=chunked, chunk_size=60_000)
    return buf.getvalue()


def _same_tables(a: thermrs.Extraction, b: thermrs.Extraction) -> None:
    for t in TABLES:
        assert_frame_equal(getattr(a, t), getattr(b, t), check_exact=True)


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("pieces", [7, 61])
def test_bytes_appended_piece_by_piece_give_extracts_tables(
    tmp_path: Path, paper_rig: thermrs.Rig, layout: str, pieces: int
) -> None:
    data = _bytes(paper_rig, layout)
    piece = len(data) // pieces + 997  # cut anywhere: inside chunks and record headers
    path = tmp_path / "live.mcap"
    path.write_bytes(b"")
    f = Follower(path, paper_rig)
    steps = []
    for i in range(0, len(data), piece):
        with path.open("ab") as fh:
            fh.write(data[i : i + piece])
        steps.append(f.step())
        assert f.state()["report"].get("losses", []) == []  # a record being written: no loss
    assert steps[-1].closed and f.closed
    assert not any(s.closed for s in steps[:-1])
    # Each byte of the data section read once: from the magic to the Data End record
    # (13 bytes before the summary section the footer points at).
    footer = len(data) - 8 - 29
    summary_start = int.from_bytes(data[footer + 9 : footer + 17], "little")
    assert sum(s.bytes_read for s in steps) == f.bytes_read == summary_start - 13 - 8
    ref = thermrs.extract(path, paper_rig)
    ex = f.extraction()
    _same_tables(ex, ref)
    assert ex.report.messages == ref.report.messages
    assert ex.report.losses == []
    # Nothing after the recording closed is read again.
    assert f.step().bytes_read == 0


def test_a_recorder_flushing_as_it_writes(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """The writer writes into the followed file itself, through Python's buffered file (its
    8 KiB blocks reach the disk as they fill, cut anywhere), flushed after each message as a
    recorder does; the follower steps after each message."""
    from mcap.writer import CompressionType, Writer

    from tests.support.recordings import ENCODERS, MSGDEFS

    path = tmp_path / "rec.mcap"
    disk = path.open("wb")
    w = Writer(disk, chunk_size=40_000, compression=CompressionType.ZSTD)
    w.start(profile="ros2", library="a recorder")
    f = Follower(path, paper_rig)
    schemas: dict[str, int] = {}
    channels: dict[str, int] = {}
    reads = []
    for seq, (topic, schema, t, msg) in enumerate(_messages(paper_rig)):
        if schema not in schemas:
            schemas[schema] = w.register_schema(schema, "ros2msg", MSGDEFS[schema].encode())
        if topic not in channels:
            channels[topic] = w.register_channel(topic, "cdr", schemas[schema])
        w.add_message(channels[topic], log_time=t, data=ENCODERS[schema](msg), publish_time=t,
                      sequence=seq)  # fmt: skip
        disk.flush()
        reads.append(f.step().bytes_read)
    assert not f.closed
    w.finish()
    disk.close()
    last = f.step()
    assert last.closed
    assert sum(r > 0 for r in reads) > 3  # it followed, chunk by chunk
    _same_tables(f.extraction(), thermrs.extract(path, paper_rig))


def test_a_writer_killed_inside_a_chunk(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    data = _bytes(paper_rig, "zstd")
    with io.BytesIO(data) as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 3
    cut_in = chunks[len(chunks) // 2]
    cut = cut_in.chunk_start_offset + cut_in.chunk_length // 2
    path = tmp_path / "killed.mcap"
    path.write_bytes(data[:cut])
    f = Follower(path, paper_rig)
    f.step()
    assert not f.closed and f.step().bytes_read == 0  # waits: the chunk may still come
    ex = f.extraction()
    assert ex.report.losses == []
    # The truth: the camera messages of the complete chunks, as the writer's chunk index
    # and the mcap package's reader of the finished file tell them (chunks hold messages in
    # time order, one after another).
    complete = [c for c in chunks if c.chunk_start_offset + c.chunk_length <= cut]
    last = max(c.message_end_time for c in complete)
    cams = {c.topic for c in paper_rig.cameras}
    expected = sum(
        1
        for _, ch, m in make_reader(io.BytesIO(data)).iter_messages(log_time_order=False)
        if ch.topic in cams and m.log_time <= last
    )
    assert expected > 0
    assert ex.frames.height == expected


def test_resumed_from_its_state_in_another_follower(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    data = _bytes(paper_rig, "lz4")
    path = tmp_path / "live.mcap"
    path.write_bytes(data[: len(data) // 2])
    f = Follower(path, paper_rig)
    f.step()
    first = f.extraction()
    g = Follower(path, paper_rig, state=f.state(), resumed=first)
    with path.open("ab") as fh:
        fh.write(data[len(data) // 2 :])
    assert g.step().closed
    _same_tables(g.extraction(), thermrs.extract(path, paper_rig))


def test_a_bag_folder_gaining_parts(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """``NAME_0.mcap``, ``NAME_1.mcap`` written one after the other; the bag is closed when
    its ``metadata.yaml`` is written (by ``rosbags``, as rosbag2's recorder leaves it)."""
    from tests.support.bags import write_bag

    msgs = _messages(paper_rig, cycles=9)
    whole = tmp_path / "whole"
    write_bag(msgs, whole, storage="mcap", cuts=(len(msgs) // 3, 2 * len(msgs) // 3))
    parts = sorted(p for p in whole.iterdir() if p.suffix == ".mcap")
    assert len(parts) == 3
    live = tmp_path / "live"
    live.mkdir()
    f = Follower(live, paper_rig)
    assert not f.step().closed  # nothing yet
    for p in parts:
        data = p.read_bytes()
        half = len(data) // 2
        (live / p.name).write_bytes(data[:half])
        assert not f.step().closed
        with (live / p.name).open("ab") as fh:
            fh.write(data[half:])
        assert not f.step().closed  # no metadata.yaml yet
    (live / "metadata.yaml").write_bytes((whole / "metadata.yaml").read_bytes())
    assert f.step().closed
    _same_tables(f.extraction(), thermrs.extract(whole, paper_rig))


def test_ros1_is_read_once_closed(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    d = tmp_path / "bag"
    d.mkdir()
    (d / "bag_0.bag").write_bytes(b"#ROSBAG V2.0\n")
    with pytest.raises(thermrs.errors.InputError, match="only MCAP and SQLite"):
        Follower(d, paper_rig).step()


def test_reports_of_consecutive_ranges_merge() -> None:
    a = {"chunks": 2, "messages": {"/a": 3}, "losses": [{"kind": "x"}], "notes": ["n"],
         "used_summary": True}  # fmt: skip
    b = {"chunks": 1, "messages": {"/a": 1, "/b": 2}, "losses": [], "notes": ["n", "m"],
         "used_summary": True}  # fmt: skip
    m = merge_reports(a, b)
    assert m["chunks"] == 3 and m["messages"] == {"/a": 4, "/b": 2}
    assert m["notes"] == ["n", "m"] and m["losses"] == [{"kind": "x"}]
    assert m["used_summary"] is False


def test_a_sqlite_bag_folder_filled_row_by_row(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """A two-part ``.db3`` bag written by ``rosbags`` (messages zstd-compressed) copied row
    batch by row batch into databases held open by their writer (Python's ``sqlite3``): each
    step reads exactly the rows committed since the last (their ``data`` bytes and camera
    frames, counted by SQLite), the bag closes when its ``metadata.yaml`` is written, and the
    tables are ``extract``'s on the finished bag."""
    import sqlite3

    from tests.support.bags import write_bag

    msgs = _messages(paper_rig, cycles=9)
    whole = tmp_path / "whole"
    write_bag(msgs, whole, storage="sqlite3", compression="message", cuts=(len(msgs) // 2,))
    parts = sorted(whole.glob("*.db3"))
    assert len(parts) == 2
    cams = tuple(c.topic for c in paper_rig.cameras)
    live = tmp_path / "live"
    live.mkdir()
    f = Follower(live, paper_rig)
    assert not f.step().closed
    for p in parts:
        w = sqlite3.connect(live / p.name, isolation_level=None)
        w.execute("ATTACH DATABASE ? AS src", (str(p),))
        for (sql,) in w.execute("SELECT sql FROM src.sqlite_master WHERE type = 'table'"):
            w.execute(sql)
        w.execute("INSERT INTO main.topics SELECT * FROM src.topics")
        ids = [i for (i,) in w.execute("SELECT id FROM src.messages ORDER BY id")]
        for a in range(0, len(ids), 37):
            lo, hi = ids[a], ids[min(a + 37, len(ids)) - 1]
            w.execute("BEGIN")
            w.execute("INSERT INTO main.messages SELECT * FROM src.messages WHERE id "
                      "BETWEEN ? AND ?", (lo, hi))  # fmt: skip
            w.execute("COMMIT")
            (n_bytes,) = w.execute("SELECT SUM(length(data)) FROM src.messages WHERE id BETWEEN"
                                   " ? AND ?", (lo, hi)).fetchone()  # fmt: skip
            (n_frames,) = w.execute(
                "SELECT COUNT(*) FROM src.messages m JOIN src.topics t ON m.topic_id = t.id "
                f"WHERE m.id BETWEEN ? AND ? AND t.name IN ({','.join('?' * len(cams))})",
                (lo, hi, *cams),
            ).fetchone()
            s = f.step()
            assert (s.bytes_read, s.new_frames, s.closed) == (n_bytes, n_frames, False)
        w.close()
    (live / "metadata.yaml").write_bytes((whole / "metadata.yaml").read_bytes())
    s = f.step()
    assert s.closed and s.bytes_read == 0
    _same_tables(f.extraction(), thermrs.extract(whole, paper_rig))
