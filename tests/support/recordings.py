"""Write small but real MCAP recordings for tests, with known truth.

Messages are encoded by ``mcap_ros2``'s own CDR serializer (the reference Python writer) and
written with the ``mcap`` package's Writer, so chunking, compression and summary can be chosen.
Spots are pixel-integrated Gaussians (erf differences) with Poisson shot noise, Gaussian read
noise, DN gain and rounding; the true centre of every frame is recorded.
"""

from __future__ import annotations

import io
import zlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap.writer import CompressionType, IndexType, Writer
from mcap_ros2._dynamic import serialize_dynamic
from scipy.special import erf

TIME_DEF = "int32 sec\nuint32 nanosec"
HEADER_DEF = "builtin_interfaces/Time stamp\nstring frame_id"
SEP = "=" * 80


def _msgdef(body: str) -> str:
    return (
        f"{body}\n{SEP}\nMSG: std_msgs/Header\n{HEADER_DEF}\n"
        f"{SEP}\nMSG: builtin_interfaces/Time\n{TIME_DEF}\n"
    )


MSGDEFS = {
    "sensor_msgs/msg/Image": _msgdef(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
        "uint8 is_bigendian\nuint32 step\nuint8[] data"
    ),
    "sensor_msgs/msg/CompressedImage": _msgdef(
        "std_msgs/Header header\nstring format\nuint8[] data"
    ),
    "sensor_msgs/msg/JointState": _msgdef(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort"
    ),
    "sensor_msgs/msg/Temperature": _msgdef(
        "std_msgs/Header header\nfloat64 temperature\nfloat64 variance"
    ),
}
ENCODERS = {name: serialize_dynamic(name, text)[name] for name, text in MSGDEFS.items()}


def header(t_ns: int, frame_id: str) -> dict[str, object]:
    return {"stamp": {"sec": t_ns // 10**9, "nanosec": t_ns % 10**9}, "frame_id": frame_id}


def spot_image(
    w: int,
    h: int,
    x: float,
    y: float,
    *,
    sigma: float = 4.0,
    peak_dn: float = 170.0,
    background_dn: float = 8.0,
    read_noise_dn: float = 1.5,
    dn_per_e: float = 0.5,
    bits: int = 8,
    rng: np.random.Generator,
) -> np.ndarray:
    """A frame with a pixel-integrated Gaussian spot centred at (x, y) (SPEC §4 pixels);
    ``peak_dn`` is the amplitude of the continuous Gaussian above background."""
    cols = np.arange(w + 1) - 0.5
    rows = np.arange(h + 1) - 0.5
    s = sigma * np.sqrt(2.0)
    ex = np.diff(erf((cols - x) / s)) / 2.0
    ey = np.diff(erf((rows - y) / s)) / 2.0
    total_dn = peak_dn * 2.0 * np.pi * sigma**2
    signal_e = np.outer(ey, ex) * total_dn / dn_per_e
    e = rng.poisson(signal_e + background_dn / dn_per_e).astype(np.float64)
    dn = e * dn_per_e + rng.normal(0.0, read_noise_dn, e.shape)
    return np.clip(np.rint(dn), 0, 2**bits - 1).astype(np.uint8 if bits == 8 else np.uint16)


def dark_image(w: int, h: int, *, bits: int = 8, rng: np.random.Generator) -> np.ndarray:
    dn = rng.poisson(16.0, (h, w)) * 0.5 + rng.normal(0.0, 1.5, (h, w))
    return np.clip(np.rint(dn), 0, 2**bits - 1).astype(np.uint8 if bits == 8 else np.uint16)


def image_msg(
    img: np.ndarray, t_ns: int, frame_id: str, *, encoding: str, pad: int = 0
) -> dict[str, object]:
    """An Image message; ``pad`` extra bytes per row (step > width × bytes per pixel)."""
    h, w = img.shape
    raw = img.astype(img.dtype.newbyteorder("<")).tobytes()
    bpp = img.dtype.itemsize
    rows = [raw[r * w * bpp : (r + 1) * w * bpp] + b"\xee" * pad for r in range(h)]
    return {
        "header": header(t_ns, frame_id),
        "height": h,
        "width": w,
        "encoding": encoding,
        "is_bigendian": 0,
        "step": w * bpp + pad,
        "data": b"".join(rows),
    }


def png_bytes(img: np.ndarray) -> bytes:
    """Lossless PNG of an 8- or 16-bit grey image (written by hand with zlib: no extra dep)."""
    h, w = img.shape
    depth = 8 if img.dtype == np.uint8 else 16
    raw = img.astype(">u2").tobytes() if depth == 16 else img.tobytes()
    stride = w * (depth // 8)
    scan = b"".join(b"\x00" + raw[r * stride : (r + 1) * stride] for r in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        c = kind + data
        return len(data).to_bytes(4, "big") + c + zlib.crc32(c).to_bytes(4, "big")

    ihdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([depth, 0, 0, 0, 0])
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(scan))
        + chunk(b"IEND", b"")
    )


@dataclass
class Recording:
    """Collects messages, then writes them as one MCAP file."""

    messages: list[tuple[str, str, int, dict[str, object]]] = field(default_factory=list)
    truth: list[dict[str, object]] = field(default_factory=list)

    def add(self, topic: str, schema: str, t_ns: int, msg: dict[str, object]) -> None:
        self.messages.append((topic, schema, t_ns, msg))

    def write(
        self,
        path: Path,
        *,
        compression: str = "zstd",
        chunk_size: int = 1 << 20,
        chunked: bool = True,
        summary: bool = True,
    ) -> Path:
        with open(path, "wb") as fh:
            write_messages(
                fh,
                self.messages,
                compression=compression,
                chunk_size=chunk_size,
                chunked=chunked,
                summary=summary,
            )
        return path


def write_messages(
    out: io.BufferedIOBase | io.BytesIO | object,
    messages: Iterable[tuple[str, str, int, dict[str, object]]],
    *,
    compression: str = "zstd",
    chunk_size: int = 1 << 20,
    chunked: bool = True,
    summary: bool = True,
) -> None:
    """Stream messages (topic, schema, t_ns, message) into an MCAP file object."""
    comp = {
        "none": CompressionType.NONE,
        "zstd": CompressionType.ZSTD,
        "lz4": CompressionType.LZ4,
    }[compression]
    w = Writer(
        out,  # type: ignore[arg-type]
        chunk_size=chunk_size,
        compression=comp,
        use_chunking=chunked,
        index_types=IndexType.ALL if summary else IndexType.NONE,
        repeat_channels=summary,
        repeat_schemas=summary,
        use_statistics=summary,
        use_summary_offsets=summary,
    )
    w.start(profile="ros2", library="thermrs-tests")
    schemas: dict[str, int] = {}
    channels: dict[str, int] = {}
    for seq, (topic, schema, t_ns, msg) in enumerate(messages):
        if schema not in schemas:
            schemas[schema] = w.register_schema(schema, "ros2msg", MSGDEFS[schema].encode())
        if topic not in channels:
            channels[topic] = w.register_channel(topic, "cdr", schemas[schema])
        w.add_message(
            channels[topic],
            log_time=t_ns + 2_000_000,
            data=ENCODERS[schema](msg),
            publish_time=t_ns,
            sequence=seq,
        )
    w.finish()


def shift_days(src: Path, dst: Path, days: int) -> Path:
    """A copy of the recording ``src`` recorded ``days`` later: every message's header stamp
    (the first field of each ROS 2 message here, after the 4-byte CDR encapsulation), its log
    and publish times and the ``thermrs.run`` markers moved by whole days, rewritten by the
    ``mcap`` package's own reader and writer."""
    import struct

    from mcap.reader import make_reader

    shift = days * 86_400 * 10**9
    with src.open("rb") as f, dst.open("wb") as out:
        r = make_reader(f)
        w = Writer(out, compression=CompressionType.ZSTD)  # type: ignore[arg-type]
        w.start(profile="ros2", library="thermrs-tests")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for sc, ch, m in r.iter_messages(log_time_order=False):
            if sc is not None and sc.id not in schemas:
                schemas[sc.id] = w.register_schema(sc.name, sc.encoding, sc.data)
            if ch.id not in channels:
                channels[ch.id] = w.register_channel(
                    ch.topic, ch.message_encoding, schemas[sc.id] if sc else 0
                )
            (sec,) = struct.unpack_from("<i", m.data, 4)
            data = bytearray(m.data)
            struct.pack_into("<i", data, 4, sec + days * 86_400)
            w.add_message(
                channels[ch.id],
                log_time=m.log_time + shift,
                data=bytes(data),
                publish_time=m.publish_time + shift,
                sequence=m.sequence,
            )
        for md in r.iter_metadata():
            values = dict(md.metadata)
            for k in ("start_ns", "end_ns"):
                if k in values:
                    values[k] = str(int(values[k]) + shift)
            w.add_metadata(md.name, values)
        w.finish()
    return dst
