"""Backs the BENCHMARKS.md claim "a 50 GB hole: extract ≤ 2× one read, < 300 MB, info < 5 s".

A recording followed by a 50 GB hole (a crashed writer that pre-allocated): thermrs reads
its data part and skips the hole, in bounded memory.

Claim (BENCHMARKS.md, "A recording followed by a 50 GB hole"): on such a file `thermrs extract`
keeps every frame before the hole, exits 3, peaks below 300 MB resident and takes at most 2× the
time of reading the data part once; `thermrs info` answers in under 5 s.

Writes an uncompressed recording of ``--frames`` 752×582 mono8 frames with the reference
writer, cuts it at 90 % of its bytes (the writer died: no summary, no footer), and extends it
with a hole of ``--hole-gb`` GB (`truncate`, no disk used). Then, each in a fresh process, in
one run: reading the data part once (`cat`-like, 1 MiB reads), `thermrs extract` and
`thermrs info` on the file with the hole, and `thermrs extract` on the cut file without it.

Run:  python benchmarks/bench_sparse.py [--frames 1000] [--hole-gb 50] [--dir bench-out/rec]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from bench_extract import make  # noqa: E402


def run(cmd: list[str]) -> tuple[float, float, int]:
    """Wall seconds, peak RSS (MB) and exit code of a command in a fresh process."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    return wall, usage.ru_maxrss / 1024, os.waitstatus_to_exitcode(status)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--hole-gb", type=float, default=50.0)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/rec"))
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    whole = args.dir / f"none-10pct-{args.frames}.mcap"
    if not whole.exists():
        make(whole, args.frames, 0.1, "none")
    cut = args.dir / f"cut-{args.frames}.mcap"
    holed = args.dir / f"hole-{args.frames}.mcap"
    data = int(whole.stat().st_size * 0.9)
    with open(whole, "rb") as src, open(cut, "wb") as dst:
        shutil.copyfileobj(src, dst, length=1 << 20)
        dst.truncate(data)
    shutil.copyfile(cut, holed)
    with open(holed, "r+b") as fh:
        fh.truncate(data + int(args.hole_gb * 1e9))
    rig = str(HERE.parent / "python" / "thermrs" / "data" / "kr15-paper.toml")
    reader = [
        sys.executable,
        "-c",
        "import sys\n"
        "f = open(sys.argv[1], 'rb', buffering=0)\n"
        "n = int(sys.argv[2]); b = bytearray(1 << 20); m = memoryview(b)\n"
        "while n > 0:\n"
        "    k = f.readinto(m[: min(n, len(b))]); n -= k\n"
        "    if not k: break\n",
        str(holed),
        str(data),
    ]
    thermrs = [sys.executable, "-m", "thermrs"]
    out = args.dir / "hole-out.parquet"
    rows = [
        ("read the data part once", reader),
        ("`thermrs extract` (with the hole)", [*thermrs, "extract", str(holed), "-o", str(out)]),
        ("`thermrs extract` (cut file, no hole)", [*thermrs, "extract", str(cut), "-o", str(out)]),
        ("`thermrs info` (with the hole)", [*thermrs, "info", str(holed)]),
    ]
    print(
        f"data part {data / 1e6:,.0f} MB, hole {args.hole_gb:g} GB, "
        f"file {holed.stat().st_size / 1e9:,.1f} GB"
    )
    print("| route | wall (s) | peak RSS (MB) | exit |")
    print("| --- | ---: | ---: | ---: |")
    base = None
    for name, cmd in rows:
        if "extract" in cmd:
            cmd = [*cmd, "--rig", rig]
        wall, rss, code = run(cmd)
        base = base or wall
        print(f"| {name} | {wall:.2f} ({wall / base:.2f}×) | {rss:,.0f} | {code} |")
    for p in (cut, holed):
        p.unlink()


if __name__ == "__main__":
    main()
