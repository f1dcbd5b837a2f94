"""Backs the BENCHMARKS.md claim "memory constant in the recording's length".

Peak memory of extraction against recording length: thermrs vs the Python route.

Writes uncompressed recordings of about 1 GB and 5 GB (752×582 mono8 frames, 10 % with a
spot, streamed to disk by the reference writer), then runs each route in a fresh process and
reports its peak resident set (ru_maxrss) and throughput. Constant memory means the peak does
not grow with the file.

Run:  python benchmarks/bench_memory.py [--sizes-gb 1 5] [--dir bench-out/rec]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_extract import make, spawn  # noqa: E402

FRAME_BYTES = 752 * 582 + 60


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes-gb", type=float, nargs="+", default=[1.0, 5.0])
    ap.add_argument("--dir", type=Path, default=Path("bench-out/rec"))
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    rows = []
    print("| recording | frames | route | threads | frames/s | peak RSS (MB) |")
    print("| --- | ---: | --- | ---: | ---: | ---: |")
    for gb in args.sizes_gb:
        frames = int(gb * 1e9 / FRAME_BYTES)
        path = args.dir / f"none-10pct-{frames}.mcap"
        if not path.exists():
            make(path, frames, 0.1, "none")
        size = path.stat().st_size / 1e9
        for route, threads in (("python", 1), ("thermrs", 1), ("thermrs", 2)):
            r = spawn(route, path, threads, 1)
            fps = frames / r["seconds"]
            name = "python (mcap + numpy)" if route == "python" else "thermrs"
            print(
                f"| {size:.2f} GB | {frames:,} | {name} | {threads} | {fps:,.0f} | "
                f"{r['peak_rss_mb']} |"
            )
            rows.append(
                {
                    "gb": size,
                    "frames": frames,
                    "route": name,
                    "threads": threads,
                    "frames_per_s": fps,
                    "peak_rss_mb": r["peak_rss_mb"],
                }
            )
    Path("bench-out/memory.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
