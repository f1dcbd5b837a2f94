"""Hostile and damaged recordings (issue 12): no crash, no abort, bounded memory, and every
intact message recovered. Truth about what each chunk held comes from the ``mcap`` Python
library's reading of the clean file, not from thermrs."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import zlib
from collections import Counter
from pathlib import Path

import pytest
import thermrs
from mcap.records import Channel, Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk

from tests.support.recordings import header

from .test_extract import cli_extract, scenario

W, H = 752, 582
FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "hostile"


def chunks(data: bytes) -> list[tuple[int, int, Counter[str]]]:
    """Each top-level chunk: (offset, end, messages per topic), by the mcap library."""
    spans, pos = [], 8
    while pos + 9 <= len(data):
        op, n = data[pos], int.from_bytes(data[pos + 1 : pos + 9], "little")
        if op == 0x06:
            spans.append((pos, pos + 9 + n))
        if op in (0x0F, 0x02):
            break
        pos += 9 + n
    topics: dict[int, str] = {}
    held: list[Counter[str]] = []
    for rec in StreamReader(io.BytesIO(data), emit_chunks=True).records:
        if isinstance(rec, Channel):
            topics[rec.id] = rec.topic
        if isinstance(rec, Chunk):
            inner = breakup_chunk(rec)
            for r in inner:
                if isinstance(r, Channel):
                    topics[r.id] = r.topic
            held.append(Counter(topics[m.channel_id] for m in inner if isinstance(m, Message)))
    assert len(held) == len(spans)
    return [(a, b, c) for (a, b), c in zip(spans, held, strict=True)]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    rig = thermrs.load_rig()
    sc = scenario(rig, cycles=6)
    d = tmp_path_factory.mktemp("hostile")
    return {
        f"{comp}{'+summary' if summary else ''}": sc.rec.write(
            d / f"{comp}-{summary}.mcap", compression=comp, chunk_size=600_000, summary=summary
        ).read_bytes()
        for comp, summary in [("zstd", True), ("zstd", False), ("none", False), ("lz4", True)]
    }


def set_u64(data: bytearray, at: int, value: int) -> None:
    data[at : at + 8] = value.to_bytes(8, "little")


DAMAGES = {
    # A chunk header's uncompressed size: ≥ 2^63 panicked, ~2^40 aborted the process.
    "uncompressed size 2^63": lambda d, a, b: set_u64(d, a + 9 + 16, 2**63),
    "uncompressed size 2^40": lambda d, a, b: set_u64(d, a + 9 + 16, 2**40),
    "uncompressed size 2^64-1": lambda d, a, b: set_u64(d, a + 9 + 16, 2**64 - 1),
    # A record length: ran past the end (everything after reported as truncated) or short.
    "record length 2^62": lambda d, a, b: set_u64(d, a + 1, 2**62),
    "record length short": lambda d, a, b: set_u64(d, a + 1, b - a - 9 - 1000),
    # A bit flip in the records: only the CRC tells.
    "bit flip": lambda d, a, b: d.__setitem__(b - 50, d[b - 50] ^ 0x04),
}


@pytest.mark.parametrize("damage", list(DAMAGES))
@pytest.mark.parametrize("layout", ["zstd+summary", "zstd", "none"])
def test_one_damaged_chunk_loses_only_itself(
    tmp_path: Path, recordings: dict[str, bytes], layout: str, damage: str
) -> None:
    rig = thermrs.load_rig()
    clean = recordings[layout]
    spans = chunks(clean)
    assert len(spans) >= 5
    a, b, held = spans[len(spans) // 2]
    bad = bytearray(clean)
    DAMAGES[damage](bad, a, b)
    path = tmp_path / "bad.mcap"
    path.write_bytes(bytes(bad))
    ex = thermrs.extract(path, rig)
    everything = dict(sum((c for _, _, c in spans), Counter()))
    if layout == "none" and damage.startswith("uncompressed"):
        # Records read in place and checked by their CRC: the size field is not needed.
        assert not ex.report.losses and ex.report.messages == everything
        return
    if layout == "none" and damage.startswith("record length"):
        # No index to jump by: the scan finds the intact records inside the uncompressed chunk,
        # so only its header is lost.
        assert ex.report.messages == everything
        [loss] = ex.report.losses
        assert (loss["offset"], loss["bytes"]) == (a, 9 + 40)
        return
    want = Counter(
        {k: v for k, v in (sum((c for _, _, c in spans), Counter()) - held).items() if v}
    )
    got = Counter({k: v for k, v in ex.report.messages.items() if v})
    assert got == want, ex.report.losses
    [loss] = ex.report.losses
    assert loss["offset"] == a and loss["offset"] + loss["bytes"] >= b
    assert f"{a}.." in loss["detail"]
    if loss["messages_lost"]:
        assert Counter(loss["messages_lost"]) == held
        assert ex.report.lost_messages == dict(held)
    if damage == "bit flip" and layout == "none":
        assert ex.report.crc_failures == 1
    p = cli_extract(path, tmp_path / "o.parquet")
    assert p.returncode == 3, p.stderr
    assert f"{a}.." in p.stderr and "Traceback" not in p.stderr


def test_report_keeps_its_old_fields(recordings: dict[str, bytes], tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    path.write_bytes(recordings["lz4+summary"])
    rep = thermrs.extract(path, thermrs.load_rig()).report
    assert not rep.data_loss and rep.losses == [] and rep.crc_failures == 0
    assert rep.chunks == len(chunks(recordings["lz4+summary"])) and rep.used_summary


def png_header_only(w: int, h: int) -> bytes:
    """A PNG whose header claims w×h and whose data is a few bytes."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        c = kind + data
        return len(data).to_bytes(4, "big") + c + zlib.crc32(c).to_bytes(4, "big")

    ihdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([8, 0, 0, 0, 0])
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))


def png_bomb(w: int, h: int) -> bytes:
    """A real decompression bomb: w×h 8-bit zeros, a few hundred kB compressed."""
    z = zlib.compressobj(9)
    row = b"\x00" * (w + 1)
    body = b"".join(z.compress(row) for _ in range(h)) + z.flush()

    def chunk(kind: bytes, data: bytes) -> bytes:
        c = kind + data
        return len(data).to_bytes(4, "big") + c + zlib.crc32(c).to_bytes(4, "big")

    ihdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([8, 0, 0, 0, 0])
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", body) + chunk(b"IEND", b"")


def worst_cases(d: Path) -> list[Path]:
    """Files built to make a reader allocate: PNG headers and bombs far larger than the rig's
    frame, chunks claiming 2^40 and 2^63 bytes, record lengths of 2^63."""
    from tests.support.recordings import Recording

    rec = Recording()
    t0 = 1_750_000_000 * 10**9
    for i, png in enumerate(
        [png_header_only(65535, 65535), png_header_only(2**31 - 1, 1), png_bomb(20000, 20000)] * 2
    ):
        t = t0 + i * 10**9
        rec.add(
            "/ccd_a/image_raw",
            "sensor_msgs/msg/CompressedImage",
            t,
            {"header": header(t, "A"), "format": "png", "data": png},
        )
    out = [rec.write(d / "png.mcap", compression="zstd", chunk_size=1 << 30)]
    base = bytearray(out[0].read_bytes())
    a, _, _ = chunks(bytes(base))[0]
    for k, value in enumerate([2**40, 2**63, 2**64 - 1, 2**35]):
        bad = bytearray(base)
        set_u64(bad, a + 9 + 16, value)
        p = d / f"size-{k}.mcap"
        p.write_bytes(bytes(bad))
        out.append(p)
        bad = bytearray(base)
        set_u64(bad, a + 1, value)
        p = d / f"length-{k}.mcap"
        p.write_bytes(bytes(bad))
        out.append(p)
    return out


def test_png_frames_larger_than_the_rig_are_refused_unread(tmp_path: Path) -> None:
    [png, *_] = worst_cases(tmp_path)
    ex = thermrs.extract(png, thermrs.load_rig())
    assert ex.frames.height == 6 and (ex.frames["status"] == "invalid").all()
    examples = " | ".join(ex.report.skipped_examples.values())
    assert "frame is 65535x65535, the rig says 752x582" in examples
    assert ex.report.skipped == {"/ccd_a/image_raw: frame is NxN, the rig says NxN": 6}


CHILD = """
import resource, sys, thermrs
rig = thermrs.load_rig()
for p in sys.argv[1:]:
    try:
        thermrs.extract(p, rig)
    except thermrs.ThermrsError as e:
        assert type(e).__name__ != "InternalError", e
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
"""


def test_memory_stays_bounded_on_the_worst_cases(tmp_path: Path) -> None:
    files = worst_cases(tmp_path)
    env = dict(os.environ, RAYON_NUM_THREADS="2")
    base = subprocess.run(
        [sys.executable, "-c", CHILD], capture_output=True, text=True, env=env, check=True
    )
    p = subprocess.run(
        [sys.executable, "-c", CHILD, *map(str, files)], capture_output=True, text=True, env=env
    )
    assert p.returncode == 0, p.stderr[-2000:]
    grown = int(p.stdout.split()[-1]) - int(base.stdout.split()[-1])
    # The bomb alone would take 400 MB per thread; a 2^40 chunk would abort the process.
    assert grown < 150, f"peak RSS grew by {grown} MB"


def test_panics_become_one_line_thermrs_errors() -> None:
    from thermrs import _native

    with pytest.raises(thermrs.ThermrsError) as e:
        _native._panic_for_tests()
    assert type(e.value).__name__ == "InternalError"
    assert "\n" not in str(e.value) and "deliberate panic" in str(e.value)
    # What a panic outside the guard would be: a BaseException `except Exception` misses.
    with pytest.raises(BaseException) as raw:
        _native._panic_for_tests(guarded=False)
    assert not isinstance(raw.value, Exception)


PANIC_CLI = """
import sys
import thermrs
import thermrs.ingest
from thermrs import _native
from thermrs.cli import main

def boom(*a, **k):
    _native._panic_for_tests(guarded={guarded})

thermrs.ingest.extract = boom
main(["extract", sys.argv[1], "--rig", str(thermrs.default_rig_path()), "-o", sys.argv[2]])
"""


@pytest.mark.parametrize("guarded", [True, False])
@pytest.mark.parametrize("debug", [False, True])
def test_cli_exits_1_with_one_line_on_a_panic(
    tmp_path: Path, recordings: dict[str, bytes], guarded: bool, debug: bool
) -> None:
    path = tmp_path / "r.mcap"
    path.write_bytes(recordings["zstd"])
    env = {k: v for k, v in os.environ.items() if k != "THERMRS_DEBUG"}
    if debug:
        env["THERMRS_DEBUG"] = "1"
    p = subprocess.run(
        [
            sys.executable,
            "-c",
            PANIC_CLI.format(guarded=guarded),
            str(path),
            str(tmp_path / "o.parquet"),
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert p.returncode == 1, p.stderr
    assert "internal error" in p.stderr and "deliberate panic" in p.stderr
    if debug:
        assert "Traceback" in p.stderr
    else:
        assert p.stderr.strip().count("\n") == 0, p.stderr


def test_crash_corpus_never_fails_internally(tmp_path: Path) -> None:
    rig = thermrs.load_rig()
    files = sorted((FIXTURES / "crashes").glob("*.mcap"))
    assert len(files) >= 4
    for p in files:
        try:
            ex = thermrs.extract(p, rig)
        except thermrs.ThermrsError as e:
            assert type(e).__name__ != "InternalError", (p, e)
            continue
        assert ex.report.data_loss or ex.report.skipped, p
        assert sum(ex.report.messages.values()) > 0, p
