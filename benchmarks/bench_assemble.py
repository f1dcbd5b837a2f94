"""Backs the BENCHMARKS.md claim "the Python after the core shrinks to ~1 % on long recordings".

What ``thermrs.extract`` spends after the Rust core, and how it grows with the frames.

``thermrs.extract`` is the core's extraction (``thermrs._native.extract``: numpy columns)
followed by Python: the polars tables, the visits and the runs (``thermrs.ingest.assemble_tables``).
This benchmark extracts one recording once with the core, then times the Python part alone on
the core's columns repeated ``K`` times (each copy's times shifted past the one before, so that
the copies are later stretches of the same recording), for each ``K`` of ``--times``. With the
core's time per frame from the same run it prints the Python part's share of a whole
extraction of a recording ``K`` times as long.

Run:  RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_assemble.py REC.mcap
      [--times 1 10 100] [--repeats 5]
(e.g. the uncompressed recording ``benchmarks/bench_checked_parts.py`` writes into its
``--dir``).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path[:0] = [str(Path(__file__).resolve().parents[1])]

import thermrs  # noqa: E402
from thermrs import _native  # noqa: E402
from thermrs.ingest import assemble_tables  # noqa: E402


def tiled(cols: dict[str, np.ndarray], k: int, span: int) -> dict[str, np.ndarray]:
    """The columns repeated ``k`` times, the ``t_ns`` of copy ``i`` shifted by ``i × span``."""
    out: dict[str, np.ndarray] = {}
    for name, v in cols.items():
        if name == "t_ns":
            out[name] = np.concatenate([v + i * span for i in range(k)])
        else:
            out[name] = np.concatenate([v] * k)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recording", type=Path)
    ap.add_argument("--times", type=int, nargs="+", default=[1, 10, 100])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    rig = thermrs.load_rig()

    def core() -> Any:
        return _native.extract(
            str(args.recording),
            rig._native,
            progress=None,
            min_sigma_px=None,
            threshold_sigma=None,
            verify_crc=True,
        )

    core()
    core_s = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        frames_c, thermal_c, joints_c, ambient_c, report = core()
        core_s.append(time.perf_counter() - t)
    n = len(frames_c["t_ns"])
    core_us = statistics.median(core_s) / n * 1e6
    stamps = [c["t_ns"] for c in (frames_c, thermal_c, joints_c, ambient_c) if len(c["t_ns"])]
    span = int(max(s.max() for s in stamps) - min(s.min() for s in stamps)) + 10**9
    print(f"{args.recording.name}: {n} CCD frames; core (checked) {core_us:.2f} µs per frame")
    for k in args.times:
        cols = tuple(tiled(c, k, span) for c in (frames_c, thermal_c, joints_c, ambient_c))
        columns = (*cols, report)
        assemble_tables(args.recording, rig, columns)  # type: ignore[arg-type]
        times = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            assemble_tables(args.recording, rig, columns)  # type: ignore[arg-type]
            times.append(time.perf_counter() - t)
        py_ms = statistics.median(times) * 1e3
        core_ms = core_us * n * k / 1e3
        print(
            f"  x{k:<4d} {n * k:>9,d} frames: Python {py_ms:8.2f} ms "
            f"({py_ms * 1e3 / (n * k):.2f} µs per frame), "
            f"{py_ms / (py_ms + core_ms):.1%} of core + Python"
        )


if __name__ == "__main__":
    main()
