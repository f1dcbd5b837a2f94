"""The mcap project's 416 conformance files (github.com/foxglove/mcap, tests/conformance/data),
written by a byte-exact port of its generator (:mod:`tests.support.mcap_conformance`), read by
``thermrs.inventory`` and ``thermrs info`` against the ``mcap`` package's own reader; and the
independent sample recording rewritten in every layout of those files (several chunks each),
extracted to the same frames as the original.

The reference reader is the ``mcap`` package's streamed reader (``NonSeekingReader``, the one
``make_reader`` returns for a stream that cannot seek), which the mcap project runs on all 416
files. Its indexed reader (``make_reader`` on a file) reads only the files whose summary has a
chunk index and repeats the schemas and channels (the project's ``py-indexed-reader`` runner
skips the others; on them it raises ``KeyError``); where it reads, it must agree.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import thermrs
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from polars.testing import assert_frame_equal

from tests.support.mcap_conformance import (
    INPUTS,
    VARIANTS,
    Attachment,
    Channel,
    Message,
    Metadata,
    Record,
    generate,
    read_records,
    variant_name,
    variants_of,
    write_layout,
)

SUPPORT = Path(__file__).resolve().parents[1] / "support"
#: name -> [size, sha256] of every published file (from the repository's Git LFS pointers).
PUBLISHED: dict[str, list[Any]] = json.loads(
    (SUPPORT / "mcap_conformance_sha256.json").read_text()
)["files"]
NAMES: dict[str, tuple[str, frozenset[str]]] = {variant_name(n, f): (n, f) for n, f in VARIANTS}


def test_the_port_writes_the_published_files_byte_for_byte() -> None:
    assert len(VARIANTS) == 416 and len(NAMES) == 416
    assert set(NAMES) == set(PUBLISHED)
    wrong = {}
    for name, (inp, features) in NAMES.items():
        data = generate(inp, features)
        got = [len(data), hashlib.sha256(data).hexdigest()]
        if got != PUBLISHED[name]:
            wrong[name] = (got, PUBLISHED[name])
    assert wrong == {}


@dataclass(frozen=True)
class Official:
    """What the ``mcap`` package's streamed reader finds in a file."""

    topics: dict[str, int]
    start_ns: int | None
    end_ns: int | None
    chunks: int
    attachments: int
    metadata: list[dict[str, Any]]


def official(data: bytes) -> Official:
    """Messages per topic, first and last log time, chunks, attachments and metadata, each by
    its own pass of the streamed reader (a ``NonSeekingReader`` answers one query)."""
    messages = [
        (channel.topic, m.log_time)
        for _, channel, m in NonSeekingReader(io.BytesIO(data)).iter_messages(log_time_order=False)
    ]
    times = [t for _, t in messages]
    records = StreamReader(io.BytesIO(data), emit_chunks=True).records
    return Official(
        topics=dict(Counter(topic for topic, _ in messages)),
        start_ns=min(times) if times else None,
        end_ns=max(times) if times else None,
        chunks=sum(isinstance(r, Chunk) for r in records),
        attachments=len(list(NonSeekingReader(io.BytesIO(data)).iter_attachments())),
        metadata=[
            {"name": md.name, "values": dict(md.metadata)}
            for md in NonSeekingReader(io.BytesIO(data)).iter_metadata()
        ],
    )


def indexed_reads(records: list[Record], features: frozenset[str]) -> bool:
    """Whether the mcap project runs its Python indexed reader on this variant
    (``PythonIndexedReaderTestRunner.supportsVariant``)."""
    has_messages = any(isinstance(r, Message) for r in records)
    return has_messages and {"ch", "chx", "rch", "rsh", "mx"} <= features


@pytest.mark.parametrize("name", list(NAMES))
def test_inventory_reads_what_the_mcap_reader_reads(tmp_path: Path, name: str) -> None:
    inp, features = NAMES[name]
    data = generate(inp, features)
    path = tmp_path / f"{name}.mcap"
    path.write_bytes(data)
    ref = official(data)
    # The reference reads the input's own records.
    records = INPUTS[inp]
    assert sum(ref.topics.values()) == sum(isinstance(r, Message) for r in records)
    assert ref.attachments == sum(isinstance(r, Attachment) for r in records)
    assert len(ref.metadata) == sum(isinstance(r, Metadata) for r in records)
    if indexed_reads(records, features):
        with path.open("rb") as fh:
            indexed = Counter(c.topic for _, c, _ in make_reader(fh).iter_messages())
        assert dict(indexed) == ref.topics

    inv = thermrs.inventory.inventory(path)
    got = {
        "topics": dict(zip(inv.topics["topic"], inv.topics["messages"], strict=True)),
        "messages": inv.messages,
        "start_ns": inv.start_ns,
        "end_ns": inv.end_ns,
        "chunks": inv.chunks,
        "metadata": inv.metadata,
        "losses": inv.losses,
    }
    want = {
        "topics": ref.topics,
        "messages": sum(ref.topics.values()),
        "start_ns": ref.start_ns,
        "end_ns": ref.end_ns,
        "chunks": ref.chunks,
        "metadata": ref.metadata,
        "losses": [],
    }
    assert got == want


#: A few of the files through ``thermrs info --json``: each input, walked (no summary) and read
#: from a summary (with and without the channels repeated there), chunked and not.
CLI_NAMES = [
    "NoData",
    "OneAttachment-ax-pad-st-sum",
    "OneMetadata-mdx-pad-st-sum",
    "OneSchemalessMessage-ch-chx-mx-pad-rch-st-sum",
    "OneMessage-ch-chx-mx-pad-rch-rsh-st-sum",
    "TenMessages",
    "TenMessages-st-sum",
    "TenMessages-ch-mx-pad",
    "TenMessages-ch-chx-mx-pad-rch-rsh-st-sum",
]


@pytest.fixture(scope="module")
def info_json(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """``thermrs info FILE… --json`` over :data:`CLI_NAMES` in one fresh process: its exit
    code and each file's entry."""
    d = tmp_path_factory.mktemp("conformance-cli")
    paths = []
    for name in CLI_NAMES:
        (d / f"{name}.mcap").write_bytes(generate(*NAMES[name]))
        paths.append(str(d / f"{name}.mcap"))
    env = {**os.environ, "THERMRS_DEBUG": ""}
    p = subprocess.run(
        [sys.executable, "-m", "thermrs", "info", *paths, "--json"],
        capture_output=True,
        text=True,
        env=env,
    )
    docs = json.loads(p.stdout) if p.stdout.strip() else []
    return {
        "returncode": p.returncode,
        "stderr": p.stderr,
        "files": {Path(doc["path"]).stem: doc for doc in docs},
    }


@pytest.mark.parametrize("name", CLI_NAMES)
def test_info_json_counts(info_json: dict[str, Any], name: str) -> None:
    assert info_json["returncode"] == 0, info_json["stderr"]
    doc = info_json["files"][name]
    ref = official(generate(*NAMES[name]))
    got = {
        "topics": {t["topic"]: t["messages"] for t in doc["topics"]},
        "messages": doc["messages"],
        "start_ns": doc["start_ns"],
        "end_ns": doc["end_ns"],
        "metadata": doc["metadata"],
        "losses": doc["losses"],
    }
    want = {
        "topics": ref.topics,
        "messages": sum(ref.topics.values()),
        "start_ns": ref.start_ns,
        "end_ns": ref.end_ns,
        "metadata": ref.metadata,
        "losses": [],
    }
    assert got == want


# --- The independent sample in every message layout ------------------------------------------

#: The feature sets of the files that carry messages (TenMessages): every valid combination of
#: ch, chx, mx, rch, rsh, st, sum and pad (154).
MESSAGE_LAYOUTS = variants_of(INPUTS["TenMessages"])
#: Messages per chunk in the rewrites (the sample's 30 messages in 8 chunks).
PER_CHUNK = 4


@dataclass(frozen=True)
class Sample:
    profile: str
    records: list[Record]
    original: thermrs.Extraction
    ccd_messages: dict[str, int]  # camera -> the mcap reader's messages on its topic


@pytest.fixture(scope="module")
def sample(shared: Path, paper_rig: thermrs.Rig) -> Sample:
    path = shared / "samples" / "kr15-sample.mcap"
    with path.open("rb") as fh:
        profile, records = read_records(fh)
    with path.open("rb") as fh:
        per_topic = Counter(c.topic for _, c, _ in make_reader(fh).iter_messages())
    original = thermrs.extract(path, paper_rig)
    assert not original.report.data_loss and original.report.skipped == {}
    return Sample(
        profile,
        records,
        original,
        {c.name: per_topic[c.topic] for c in paper_rig.cameras},
    )


def check_same_extraction(path: Path, sample: Sample, rig: thermrs.Rig) -> None:
    ex = thermrs.extract(path, rig)
    per_camera = dict(Counter(ex.frames["camera"].to_list()))
    got = {
        "frames per camera": per_camera,
        "messages": ex.report.messages,
        "skipped": ex.report.skipped,
        "losses": ex.report.losses,
        "lost": ex.report.lost_messages,
        "notes": ex.report.notes,
    }
    want = {
        "notes": [],
        "frames per camera": sample.ccd_messages,
        "messages": sample.original.report.messages,
        "skipped": {},
        "losses": [],
        "lost": {},
    }
    assert got == want
    assert_frame_equal(ex.frames, sample.original.frames)
    assert_frame_equal(ex.temperatures, sample.original.temperatures)
    assert_frame_equal(ex.joints, sample.original.joints)


@pytest.mark.parametrize(
    "features", MESSAGE_LAYOUTS, ids=[variant_name("kr15", f) for f in MESSAGE_LAYOUTS]
)
def test_sample_in_every_layout_extracts_the_same_frames(
    tmp_path: Path, sample: Sample, paper_rig: thermrs.Rig, features: frozenset[str]
) -> None:
    path = tmp_path / "r.mcap"
    path.write_bytes(
        write_layout(sample.records, features, messages_per_chunk=PER_CHUNK, profile=sample.profile)
    )
    try:
        check_same_extraction(path, sample, paper_rig)
    finally:
        path.unlink()


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_sample_in_compressed_chunks_extracts_the_same_frames(
    tmp_path: Path, sample: Sample, paper_rig: thermrs.Rig, compression: str
) -> None:
    pytest.importorskip({"zstd": "zstandard", "lz4": "lz4.frame"}[compression])
    path = tmp_path / "r.mcap"
    features = {"ch", "mx", "chx", "st", "rch", "rsh", "sum"}
    path.write_bytes(
        write_layout(
            sample.records,
            features,
            chunk_bytes=1 << 20,
            compression=compression,
            profile=sample.profile,
        )
    )
    n_chunks = sum(isinstance(r, Chunk) for r in StreamReader(str(path), emit_chunks=True).records)
    assert n_chunks > 2
    check_same_extraction(path, sample, paper_rig)


def test_sample_rewrite_is_read_alike_by_the_mcap_reader(sample: Sample) -> None:
    """The rewrite carries the original's messages: the mcap reader finds the same messages
    per topic in the richest and the barest layout."""
    for features in ({"ch", "mx", "chx", "st", "rch", "rsh", "sum", "pad"}, set()):
        data = write_layout(
            sample.records, features, messages_per_chunk=PER_CHUNK, profile=sample.profile
        )
        got = Counter(
            (c.topic, m.log_time, m.data)
            for _, c, m in make_reader(io.BytesIO(data)).iter_messages(log_time_order=False)
        )
        topics = {r.id: r.topic for r in sample.records if isinstance(r, Channel)}
        want = Counter(
            (topics[r.channel_id], r.log_time, r.data)
            for r in sample.records
            if isinstance(r, Message)
        )
        assert got == want
