"""Backs the BENCHMARKS.md claims "unchecked extraction ≥ 1.0× one read" and "checked ≥ 0.9×".

Extraction against reading the file once, with and without the chunk CRC check, in one process.

For each recording, three routes run interleaved (rotating order, so that all see the same
machine load), file in the page cache:

- ``read``: the file read once, start to end, into one reused 16 MiB buffer
  (``readinto``): the cost of touching every byte once, the floor any reader pays;
- ``checked``: ``thermrs.extract(path, rig)`` (chunk CRC-32s verified, the default);
- ``unchecked``: ``thermrs.extract(path, rig, verify_crc=False)``;
- ``core checked`` / ``core unchecked``: the Rust core's extraction alone
  (``thermrs._native.extract``: the tables as numpy columns, before polars, visits and runs);
- ``crc only``: every chunk's CRC-32 computed in place through the map and nothing else
  (``thermrs._native.checksum_chunks``): the floor of a checked extraction, which must touch
  every byte at least once;
- ``touch pages``: the file mapped (``mmap``) and one byte of every 4 kB page read, by numpy,
  nothing else: what reaching every page of the file through a map costs this page cache (no
  thermrs code). A route that maps the file and must look at every page (the sparse row scan
  does: a page holds 5.4 rows of the CCD image, the scan reads every 4th) cannot be faster;
  where it is slower than ``read``, no mapped route reaches 1.0×, and a copying route pays one
  read plus its work.

Prints the median of ``--repeats`` (≥ 5) times of each route and the speed ratios
``read time / extract time`` (≥ 1: extraction as fast as reading the file once), and the
load average at the start and the end (the machine may be shared).

Run:  RAYON_NUM_THREADS=1 python benchmarks/bench_crc.py [--repeats 9] REC.mcap [REC.mcap ...]
(e.g. the uncompressed recordings ``benchmarks/bench_extract.py`` writes into its ``--dir``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import thermrs
from thermrs import _native


def read_once(path: Path, buf: bytearray) -> int:
    """Read the whole file once into ``buf`` (reused): bytes read."""
    view = memoryview(buf)
    n = 0
    with open(path, "rb", buffering=0) as fh:
        while True:
            k = fh.readinto(view)
            if not k:
                return n
            n += k


def touch_pages(path: Path) -> int:
    """Map the file and read one byte of every 4 kB page (numpy over ``mmap``): their sum."""
    import mmap

    import numpy as np

    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as m:
        a = np.frombuffer(m, np.uint8)
        total = int(a[::4096].sum())
        del a  # release the buffer before the map closes
    return total


def core(path: Path, rig: thermrs.Rig, crc: bool) -> object:
    """The Rust core's extraction alone (no polars tables, visits or runs)."""
    return _native.extract(
        str(path),
        rig._native,
        progress=None,
        min_sigma_px=None,
        threshold_sigma=None,
        verify_crc=crc,
    )


def interleaved(routes: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Median seconds of each route over ``repeats`` rounds, the routes run in rotating order
    (each round starts one route later), so that all see the same machine load."""
    names = list(routes)
    times: dict[str, list[float]] = {k: [] for k in names}
    for i in range(repeats):
        k = i % len(names)
        for name in names[k:] + names[:k]:
            t0 = time.perf_counter()
            routes[name]()
            times[name].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", type=Path)
    ap.add_argument("--repeats", type=int, default=9)
    args = ap.parse_args()
    rig = thermrs.load_rig()
    buf = bytearray(16 << 20)
    print(f"load average at start: {os.getloadavg()[0]:.2f}")
    for path in args.recordings:
        routes: dict[str, Callable[[], object]] = {
            "read": lambda p=path: read_once(p, buf),
            "checked": lambda p=path: thermrs.extract(p, rig),
            "unchecked": lambda p=path: thermrs.extract(p, rig, verify_crc=False),
            "core checked": lambda p=path: core(p, rig, True),
            "core unchecked": lambda p=path: core(p, rig, False),
            "crc only": lambda p=path: _native.checksum_chunks(str(p)),
            "touch pages": lambda p=path: touch_pages(p),
        }
        names = list(routes)
        for name in names:  # warm: page cache, first-call costs
            routes[name]()
        med = interleaved(routes, args.repeats)
        size = path.stat().st_size
        print(
            f"{path.name} ({size / 1e6:,.0f} MB): median read {med['read'] * 1e3:.0f} ms "
            f"({size / med['read'] / 1e9:.1f} GB/s); speed vs one read (median of "
            f"{args.repeats}): "
            + ", ".join(f"{k} {med['read'] / med[k]:.2f}×" for k in names if k != "read")
        )
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
