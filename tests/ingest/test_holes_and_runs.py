"""A recording a crashed writer left: its data, then a hole (sparse, never written) or zeros it
reserved; and what ``info`` finds in recordings thermrs did not write.

The truth is the recording's own frames: extraction of the intact file (read by the same
reader on a file with no hole and no zeros), and the ``mcap`` package's count of messages per
topic. A hole must cost nothing to read: it is neither mapped nor scanned (the 50 GB case is
benchmarked, BENCHMARKS.md; here a 2 GiB hole is enough to make a scan or a map show).
"""

from __future__ import annotations

import resource
import shutil
from collections import Counter
from pathlib import Path

import pytest
import thermrs
from blake3 import blake3
from mcap.reader import make_reader
from polars.testing import assert_frame_equal
from thermrs.campaigns.sources import content_hash

from tests.support.mcap_conformance import read_records, write_layout

HOLE = 2 << 30


def _sample(shared: Path) -> Path:
    return shared / "samples" / "kr15-sample.mcap"


def _cut(src: Path, dst: Path, fraction: float) -> int:
    data = src.read_bytes()
    n = int(len(data) * fraction)
    dst.write_bytes(data[:n])
    return n


@pytest.mark.parametrize("tail", ["hole", "zeros"])
def test_a_recording_followed_by_a_hole_or_zeros_keeps_every_frame(
    tmp_path: Path, shared: Path, paper_rig: thermrs.Rig, tail: str
) -> None:
    cut = tmp_path / "cut.mcap"
    n = _cut(_sample(shared), cut, 0.8)
    clean = thermrs.extract(cut, paper_rig)
    holed = tmp_path / f"{tail}.mcap"
    shutil.copyfile(cut, holed)
    with holed.open("r+b") as fh:
        if tail == "hole":
            fh.truncate(n + HOLE)
        else:
            fh.seek(n)
            fh.write(b"\0" * (3 << 20))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    ex = thermrs.extract(holed, paper_rig)
    grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert_frame_equal(ex.frames, clean.frames)
    assert_frame_equal(ex.temperatures, clean.temperatures)
    kinds = [loss["kind"] for loss in ex.report.losses]
    # The cut chunk's complete messages are recovered (a loss says so); after it, the zeros or
    # the hole are one loss that says what they are, up to the end of the file.
    assert kinds == ["truncated", tail], ex.report.losses
    last = ex.report.losses[-1]
    assert last["offset"] + last["bytes"] == holed.stat().st_size
    if tail == "hole":
        # Not one page of the 2 GiB hole was mapped in.
        assert grown_mb < 200
    inv = thermrs.inventory.inventory(holed, rig=paper_rig)
    assert inv.losses
    assert inv.bytes == holed.stat().st_size


def test_the_content_hash_is_blake3_of_the_bytes_and_the_extraction_agrees(
    tmp_path: Path, shared: Path, paper_rig: thermrs.Rig
) -> None:
    rec = _sample(shared)
    assert content_hash(rec) == blake3(rec.read_bytes()).hexdigest()
    ex = thermrs.extract(rec, paper_rig, content_hash=True)
    assert ex.report.content_hash == content_hash(rec)
    holed = tmp_path / "holed.mcap"
    n = _cut(rec, holed, 0.8)
    with holed.open("r+b") as fh:
        fh.truncate(n + HOLE)
    ex = thermrs.extract(holed, paper_rig, content_hash=True)
    assert ex.report.content_hash == content_hash(holed)


def _info_counts(path: Path, rig: thermrs.Rig) -> tuple[int, int]:
    inv = thermrs.inventory.inventory(path, rig=rig)
    return inv.runs.height, int(inv.runs["visits"].sum())


@pytest.mark.parametrize("features", [{"ch", "mx", "chx", "st", "sum", "rch", "rsh"}, set()])
def test_info_finds_the_runs_and_visits_extract_finds(
    tmp_path: Path, shared: Path, paper_rig: thermrs.Rig, features: set[str]
) -> None:
    """On the independent sample, chunked with indexes or written without chunks (no message
    index: the log times come from the data section), ``info`` counts the runs and visits
    ``extract`` finds, and every message on its topic."""
    with _sample(shared).open("rb") as fh:
        profile, records = read_records(fh)
    with _sample(shared).open("rb") as fh:
        per_topic = Counter(c.topic for _, c, _ in make_reader(fh).iter_messages())
    path = tmp_path / "layout.mcap"
    path.write_bytes(write_layout(records, features, messages_per_chunk=4, profile=profile))
    ex = thermrs.extract(path, paper_rig)
    runs, visits = _info_counts(path, paper_rig)
    assert (runs, visits) == (ex.runs.height, ex.visits.height)
    inv = thermrs.inventory.inventory(path, rig=paper_rig)
    assert dict(zip(inv.topics["topic"], inv.topics["messages"], strict=True)) == per_topic
    assert inv.losses == []
