"""Backs the BENCHMARKS.md claim "thermrs info in about a second whatever the size".

`thermrs info` on a long recording: wall time of the command (and of the library call) on a
recording with a summary and on the same file cut short (no summary: walked record by record),
beside counting its messages with the `mcap` package's reader (what a user would otherwise do).

    python benchmarks/bench_info.py [--recording REC.mcap] [--out bench-out/info]

Without --recording it simulates the paper's three 15-hour runs
(fixtures/scenarios/paper-runs.toml, ~2.5 GB, ~5 min) into --out first.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import thermrs

REPO = Path(__file__).resolve().parents[1]


def wall(args: list[str], repeats: int) -> tuple[float, int]:
    times, rc = [], 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        rc = subprocess.run(args, capture_output=True, check=False).returncode
        times.append(time.perf_counter() - t0)
    return statistics.median(times), rc


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--recording", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=Path("bench-out/info"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-mcap", action="store_true", help="Skip the mcap package's count.")
    a = ap.parse_args()
    rig = str(thermrs.default_rig_path())
    rec = a.recording
    if rec is None:
        a.out.mkdir(parents=True, exist_ok=True)
        rec = a.out / "paper.mcap"
        if not rec.exists():
            sc = REPO / "fixtures" / "scenarios" / "paper-runs.toml"
            subprocess.run(
                [sys.executable, "-m", "thermrs", "simulate", "--rig", rig, "--scenario", str(sc),
                 "-o", str(rec)],
                check=True,
            )  # fmt: skip
    cut = a.out / "cut.mcap"
    a.out.mkdir(parents=True, exist_ok=True)
    if not cut.exists():
        with open(rec, "rb") as src, open(cut, "wb") as dst:
            dst.write(src.read(rec.stat().st_size // 2))
    inv = thermrs.inventory.inventory(rec, rig=rig)
    h = inv.duration_s / 3600
    print(f"{rec}: {inv.bytes / 1e9:.2f} GB, {inv.messages:,} messages, {h:.1f} h, "
          f"{inv.runs.height} runs, {inv.chunks} chunks")  # fmt: skip
    for label, path in (("with summary", rec), ("cut in half, no summary", cut)):
        cmd = [sys.executable, "-m", "thermrs", "info", str(path), "--rig", rig]
        t, rc = wall(cmd, a.repeats)
        t0 = time.perf_counter()
        thermrs.inventory.inventory(path, rig=rig)
        lib = time.perf_counter() - t0
        print(f"| thermrs info, {label} | {t:.2f} s (exit {rc}) | library call {lib:.3f} s |")
    if not a.no_mcap:
        from mcap.reader import make_reader

        t0 = time.perf_counter()
        with open(rec, "rb") as f:
            n = sum(1 for _ in make_reader(f).iter_messages())
        print(f"| mcap reader, counting every message | {time.perf_counter() - t0:.2f} s "
              f"({n:,} messages) |")  # fmt: skip


if __name__ == "__main__":
    main()
