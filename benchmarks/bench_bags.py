"""Backs the BENCHMARKS.md claim "rosbag2 forms within 1.5× the MCAP form on one core".

Extraction time of the same messages stored as rosbag2 bags against one MCAP file, one rayon
thread (``RAYON_NUM_THREADS=1``), each route in its own process, the file read once before
timing (page cache), best of ``--repeats``; peak RSS beside it.

Messages: those of ``bench_extract.py`` (``--frames`` 752×582 mono8 frames of the paper rig's
two cameras, 10 % with a spot, joint states, thermal frames and ambient readings). Forms, each
written by a writer thermrs does not use:

- ``mcap-none`` / ``mcap-zstd``: one MCAP file (the ``mcap`` package, 4 MiB chunks);
- ``db3``: a rosbag2 SQLite bag (``rosbags``), uncompressed, single file;
- ``db3-3-parts``: the same split into three files with one ``metadata.yaml``;
- ``db3-message-zstd``: each message compressed with zstd (rosbag2's message compression);
- ``mcap-bag-3-parts``: a rosbag2 MCAP bag (``rosbags``) in three files;
- ``ros1-none`` / ``ros1-lz4`` / ``ros1-bz2``: a ROS 1 bag, ``rosbags-convert`` of the ``db3``
  bag (ROS 1 serialization), chunks uncompressed, lz4 or bz2.

Ratios: each uncompressed form against ``mcap-none``, the message-compressed ``.db3`` against
``mcap-zstd``, ROS 1 lz4 against MCAP lz4 and ROS 1 bz2 (no MCAP form has bz2) against
``mcap-zstd``; by wall time and by the process's CPU time (the
steadier of the two on a machine shared with other work).

Run:  python benchmarks/bench_bags.py [--frames 2000] [--dir bench-out/bags] [--repeats 3]
      [--forms mcap-none,ros1-none,...]  (some forms only: the ratios of the pairs measured)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

FORMS = [
    "mcap-none",
    "mcap-zstd",
    "mcap-lz4",
    "db3",
    "db3-3-parts",
    "db3-message-zstd",
    "mcap-bag-3-parts",
    "ros1-none",
    "ros1-lz4",
    "ros1-bz2",
]


def make(form: str, path: Path, frames: int) -> None:
    from bench_extract import messages

    from tests.support.bags import write_bag, write_ros1
    from tests.support.recordings import write_messages

    if path.exists():
        return
    msgs = messages(frames, 0.1)
    n = frames + 3 * (frames // 20)
    thirds = (n // 3, 2 * n // 3)
    if form in ("mcap-none", "mcap-zstd", "mcap-lz4"):
        with open(path, "wb") as fh:
            write_messages(fh, msgs, compression=form.split("-")[1], chunk_size=4 << 20)
    elif form == "db3":
        write_bag(msgs, path)
    elif form == "db3-3-parts":
        write_bag(msgs, path, cuts=thirds)
    elif form == "db3-message-zstd":
        write_bag(msgs, path, compression="message")
    elif form == "mcap-bag-3-parts":
        write_bag(msgs, path, storage="mcap", cuts=thirds)
    elif form.startswith("ros1-"):
        write_ros1(msgs, path, compression=form.split("-")[1])


def warm(path: Path) -> None:
    for f in [path] if path.is_file() else sorted(path.iterdir()):
        with open(f, "rb") as fh:
            while fh.read(16 << 20):
                pass


def child(path: Path, repeats: int) -> None:
    import resource

    import thermrs

    rig = thermrs.load_rig()
    warm(path)
    best, cpu, n = float("inf"), float("inf"), 0
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        n = thermrs.extract(path, rig).frames.height
        best = min(best, time.perf_counter() - t)
        cpu = min(cpu, time.process_time() - c)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024
    print(json.dumps({"seconds": best, "cpu_seconds": cpu, "frames": n, "peak_rss_mb": rss}))


def spawn(path: Path, repeats: int) -> dict[str, float]:
    env = dict(os.environ, RAYON_NUM_THREADS="1", OMP_NUM_THREADS="1")
    p = subprocess.run(
        [sys.executable, __file__, "--child", "--path", str(path), "--repeats", str(repeats)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(p.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def size(path: Path) -> int:
    return path.stat().st_size if path.is_file() else sum(f.stat().st_size for f in path.iterdir())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/bags"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--forms", default=",".join(FORMS), help="comma-separated forms to measure")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--path", type=Path, default=None, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        child(a.path, a.repeats)
        return
    a.dir.mkdir(parents=True, exist_ok=True)
    res: dict[str, dict[str, float]] = {}
    forms = a.forms.split(",")
    unknown = set(forms) - set(FORMS)
    if unknown:
        ap.error(f"unknown forms: {', '.join(sorted(unknown))} (known: {', '.join(FORMS)})")
    for form in forms:
        ext = {"mcap-none": ".mcap", "mcap-zstd": ".mcap", "mcap-lz4": ".mcap"}
        path = a.dir / (f"{form}-{a.frames}" + ext.get(form, ".bag" if "ros1" in form else ""))
        make(form, path, a.frames)
        r = spawn(path, a.repeats)
        r["mb"] = size(path) / 1e6
        res[form] = r
        print(
            f"{form:18s} {r['mb']:8.1f} MB  {r['seconds']:7.3f} s wall  "
            f"{r['cpu_seconds']:7.3f} s CPU  {r['frames']:6.0f} frames  "
            f"peak RSS {r['peak_rss_mb']:5.0f} MB",
            flush=True,
        )
    frames = {r["frames"] for r in res.values()}
    assert len(frames) == 1, f"the forms gave different frame counts: {frames}"
    pairs = [(f, "mcap-none") for f in ("db3", "db3-3-parts", "mcap-bag-3-parts")]
    pairs += [("db3-message-zstd", "mcap-zstd"), ("ros1-none", "mcap-none")]
    pairs += [("ros1-lz4", "mcap-lz4"), ("ros1-bz2", "mcap-zstd")]
    for form, base in pairs:
        if form not in res or base not in res:
            continue
        x, y = res[form], res[base]
        print(
            f"{form} / {base}: {x['seconds'] / y['seconds']:.2f}x wall, "
            f"{x['cpu_seconds'] / y['cpu_seconds']:.2f}x CPU"
        )


if __name__ == "__main__":
    main()
