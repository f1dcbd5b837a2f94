"""Recordings thermrs did not write: an independent writer's sample (no run markers) and copies
of it made with the official ``mcap`` Python writer, for campaigns that must take any
recording.

:func:`rewrite` copies a recording's schemas, channels and messages into a new file (chosen
compression and chunking), its times shifted by whole seconds: the MCAP log and publish times
and the header stamp inside every CDR payload (the sensor time thermrs reads, SPEC §2).
:func:`cut` truncates a file as a crash or a full disk leaves it. :func:`foreign_campaign`
makes the folder of the campaign tests: the sample as is, the same bytes again under another
name, a copy hours later, one overlapping it in time, and one cut short.
"""

from __future__ import annotations

import shutil
import struct
from pathlib import Path
from typing import Literal

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

__all__ = ["CUT_NAME", "cut", "foreign_campaign", "rewrite", "sample_path", "shift_stamp"]

#: The shared folder's sample of an independent writer, relative to that folder.
SAMPLE = Path("samples") / "kr15-sample.mcap"

#: The file of :func:`foreign_campaign` that is cut short (exit 3 for a campaign holding it).
CUT_NAME = "cut.mcap"

Compression = Literal["none", "zstd", "lz4"]
_COMPRESSION = {"none": CompressionType.NONE, "zstd": CompressionType.ZSTD,
                "lz4": CompressionType.LZ4}  # fmt: skip


def sample_path(shared: Path) -> Path:
    """The independent writer's sample recording in the shared folder."""
    return shared / SAMPLE


def shift_stamp(payload: bytes, shift_s: int) -> bytes:
    """A CDR message whose first field is a ``std_msgs/Header`` (every type thermrs reads),
    its header stamp's seconds moved by ``shift_s``; the byte order from the encapsulation
    header (an odd second byte: little-endian, plain or XCDR2)."""
    if shift_s == 0:
        return payload
    fmt = "<i" if payload[1] & 1 else ">i"
    (sec,) = struct.unpack_from(fmt, payload, 4)
    out = bytearray(payload)
    struct.pack_into(fmt, out, 4, sec + shift_s)
    return bytes(out)


def rewrite(
    src: Path,
    dst: Path,
    *,
    shift_s: int = 0,
    compression: Compression = "zstd",
    chunk_size: int = 1 << 20,
    chunked: bool = True,
) -> Path:
    """Copy ``src`` into ``dst`` with the ``mcap`` package's Writer, every time moved by
    ``shift_s`` seconds; ``dst``."""
    with open(src, "rb") as fi, open(dst, "wb") as fo:
        reader = make_reader(fi)
        writer = Writer(
            fo,
            compression=_COMPRESSION[compression],
            chunk_size=chunk_size,
            use_chunking=chunked,
        )
        writer.start(profile=reader.get_header().profile, library="thermrs-tests/foreign")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        ns = shift_s * 10**9
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schemas[schema.id] if schema is not None else 0,
                    dict(channel.metadata),
                )
            writer.add_message(
                channels[channel.id],
                log_time=message.log_time + ns,
                data=shift_stamp(message.data, shift_s),
                publish_time=message.publish_time + ns,
                sequence=message.sequence,
            )
        writer.finish()
    return dst


def cut(src: Path, dst: Path, *, fraction: float = 0.6) -> Path:
    """``dst``: the first ``fraction`` of ``src``'s bytes (a recording cut short)."""
    data = src.read_bytes()
    dst.write_bytes(data[: int(len(data) * fraction)])
    return dst


def foreign_campaign(sample: Path, folder: Path) -> dict[str, Path]:
    """A folder of recordings without run markers, none written by thermrs; name → path.

    - ``sample``: the independent writer's file as it is;
    - ``duplicate``: the same bytes under another name;
    - ``later``: rewritten (lz4 chunks) six hours later;
    - ``overlap``: rewritten unchunked, ten minutes later: it overlaps ``sample`` in time;
    - ``cut``: rewritten (zstd chunks) a day later, then cut at 60 % of its bytes.
    """
    folder.mkdir(parents=True, exist_ok=True)
    out = {
        "sample": folder / "sample.mcap",
        "duplicate": folder / "duplicate.mcap",
        "later": folder / "later.mcap",
        "overlap": folder / "overlap.mcap",
        "cut": folder / CUT_NAME,
    }
    shutil.copyfile(sample, out["sample"])
    shutil.copyfile(sample, out["duplicate"])
    rewrite(sample, out["later"], shift_s=6 * 3600, compression="lz4", chunk_size=600_000)
    rewrite(sample, out["overlap"], shift_s=600, compression="none", chunked=False)
    whole = folder / "cut.whole"
    rewrite(sample, whole, shift_s=24 * 3600, compression="zstd", chunk_size=300_000)
    cut(whole, out["cut"])
    whole.unlink()
    return out
