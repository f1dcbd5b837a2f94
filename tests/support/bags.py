"""The same messages written in every form a ROS lab keeps, by writers thermrs does not use:
one MCAP file (the ``mcap`` package, :func:`tests.support.recordings.write_messages`),
rosbag2 bags written by ``rosbags`` (its MCAP and SQLite storages, whole or compressed with
zstd per file or per message), single or split into parts with their ``metadata.yaml``, and
ROS 1 bags converted from those by ``rosbags-convert`` (chunks uncompressed, bz2 or lz4; each
message turned from CDR into ROS 1's serialization by ``rosbags``).

A split bag is written as ``ros2 bag record --max-bag-size`` leaves it: one folder,
``NAME_0.EXT``, ``NAME_1.EXT``, … and one ``metadata.yaml`` listing them in order, each part
written by ``rosbags`` and the metadata of the parts joined (``relative_file_paths``,
``files``, counts and time span), as rosbag2's recorder writes it after a split.
"""

from __future__ import annotations

import io
import itertools
import shutil
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.typesys import Stores, get_typestore
from ruamel.yaml import YAML

from tests.support.recordings import ENCODERS, header, write_messages

Message = tuple[str, str, int, dict[str, object]]

#: What ``rosbags`` stamps each message with: the log time the ``mcap`` package writes
#: (:func:`~tests.support.recordings.write_messages`: the stamp + 2 ms).
LOG_DELAY_NS = 2_000_000


def shifted(messages: Sequence[Message], shift_ns: int) -> list[Message]:
    """The messages recorded ``shift_ns`` later: header stamps and times moved."""
    out: list[Message] = []
    for topic, schema, t, msg in messages:
        m = dict(msg)
        h = msg["header"]
        assert isinstance(h, dict)
        st = h["stamp"]
        assert isinstance(st, dict)
        m["header"] = header(int(st["sec"]) * 10**9 + int(st["nanosec"]) + shift_ns, h["frame_id"])
        out.append((topic, schema, t + shift_ns, m))
    return out


def write_mcap(messages: Sequence[Message], path: Path) -> Path:
    """One MCAP file (the ``mcap`` package)."""
    with path.open("wb") as fh:
        write_messages(fh, messages)
    return path


def _rosbags_bag(
    messages: Iterable[Message], folder: Path, *, storage: str, compression: str
) -> Path:
    """One rosbag2 bag written by ``rosbags`` (``compression``: none, file or message)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    w = Writer(folder, version=9, storage_plugin=plugin)
    if compression != "none":
        mode = CompressionMode.FILE if compression == "file" else CompressionMode.MESSAGE
        w.set_compression(mode, CompressionFormat.ZSTD)
    with w:
        conns: dict[str, Any] = {}
        for topic, schema, t, msg in messages:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, schema, typestore=store)
            w.write(conns[topic], t + LOG_DELAY_NS, ENCODERS[schema](msg))
    return folder


def write_bag(
    messages: Iterable[Message],
    folder: Path,
    *,
    storage: str = "sqlite3",
    compression: str = "none",
    cuts: Sequence[int] = (),
    metadata: bool = True,
) -> Path:
    """A rosbag2 bag folder of the messages (streamed), split before each index in ``cuts``
    into parts ``NAME_0``, ``NAME_1``, … (``metadata=False``: without ``metadata.yaml``)."""
    bounds: list[int | None] = [0, *cuts, None]
    stream = iter(messages)
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    folder.mkdir()
    infos: list[dict[str, Any]] = []
    for i, (a, b) in enumerate(itertools.pairwise(bounds)):
        tmp = folder.parent / f".{folder.name}-part{i}"
        assert a is not None
        part = itertools.islice(stream, None if b is None else b - a)
        _rosbags_bag(part, tmp, storage=storage, compression=compression)
        info = yaml.load((tmp / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        (src,) = info["relative_file_paths"]
        name = f"{folder.name}_{i}" + src[len(tmp.name) :]
        (tmp / src).rename(folder / name)
        info["relative_file_paths"] = [name]
        info["files"][0]["path"] = name
        infos.append(info)
        shutil.rmtree(tmp)
    if metadata:
        joined = dict(infos[0])
        joined["relative_file_paths"] = [x["relative_file_paths"][0] for x in infos]
        joined["files"] = [x["files"][0] for x in infos]
        joined["message_count"] = sum(x["message_count"] for x in infos)
        start = min(x["starting_time"]["nanoseconds_since_epoch"] for x in infos)
        end = max(
            x["starting_time"]["nanoseconds_since_epoch"] + x["duration"]["nanoseconds"]
            for x in infos
        )
        joined["starting_time"] = {"nanoseconds_since_epoch": start}
        joined["duration"] = {"nanoseconds": end - start}
        counts: dict[str, dict[str, Any]] = {}
        for x in infos:
            for t in x["topics_with_message_count"]:
                name = t["topic_metadata"]["name"]
                if name in counts:
                    counts[name]["message_count"] += t["message_count"]
                else:
                    counts[name] = dict(t)
        joined["topics_with_message_count"] = list(counts.values())
        text = io.StringIO()
        yaml.dump({"rosbag2_bagfile_information": joined}, text)
        (folder / "metadata.yaml").write_text(text.getvalue())
    return folder


def write_ros1(messages: Iterable[Message], path: Path, *, compression: str = "none") -> Path:
    """A ROS 1 bag of the messages: a rosbag2 SQLite bag written by ``rosbags``, converted by
    ``rosbags-convert`` (CDR to ROS 1's serialization; ``compression``: none, bz2 or lz4)."""
    import subprocess
    import sys
    import tempfile

    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        src = write_bag(messages, Path(tmp) / "src")
        tool = Path(sys.executable).parent / "rosbags-convert"
        subprocess.run(
            [str(tool), "--src", str(src), "--dst", str(path), "--compress", compression],
            check=True,
            capture_output=True,
        )
    return path
