"""How fast a checked extraction could be on one core if memory cost nothing: the least time a
one-core checked extraction can take, against one read of the file.

A checked extraction on one core does two things: it brings every byte of the file from memory
(the ``crc only`` route, measured on the big recording), and it computes (the CRC and the
frames' interpretation). Even if the two overlapped perfectly, its time could not be less than
the larger of them. The compute alone is measured where memory costs next to nothing: on two
small recordings of the same frames (``--small`` and twice as many), whose bytes stay in the
CPU's last-level cache (32 MB here) between repeats; the difference of their times per added
frame is the per-frame cost without the memory stream and without the per-call costs. It is
the extraction as built, reaching its bytes by the route its chooser picks (for cache-resident
files, often a copy through the kernel), so it overstates the compute alone, and the bound
below is a lower estimate of the true one. The script prints, per frame:

- ``read``: the big recording read once into a reused 16 MiB buffer (the baseline);
- ``crc only`` on the big recording: the memory stream every checked route must pay;
- ``core checked`` / ``core unchecked`` / ``crc only`` in cache: the per-frame compute;
- ``core checked`` on the big recording: what the extraction takes now;
- the **bound**: read / max(crc only big, core checked in cache), the fastest a checked
  extraction of this file could run on one core, as a multiple of one read.

Recordings: ``benchmarks/bench_extract.py``'s ``make`` (752×582 mono8 frames, 10 % spots,
uncompressed, 4 MiB chunks). The big one is written first (``--frames``, default 2,000:
891 MB, fresh in the page cache, where mapping is cheapest) unless ``--big`` names one.
Each round measures everything once (medians of repeats inside), ``--rounds`` rounds.

Run:  RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/experiments/bench_checked_bound.py
      [--big REC.mcap] [--small 20] [--rounds 5] [--dir bench-out/bound]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path[:0] = [str(Path(__file__).resolve().parents[1]), str(Path(__file__).resolve().parents[2])]


def _median(g: Callable[[], object], reps: int) -> float:
    g()
    g()
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        g()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def main() -> None:
    import thermrs
    from bench_extract import make
    from thermrs import _native

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--big", type=Path, default=None)
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--small", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/bound"))
    a = ap.parse_args()
    a.dir.mkdir(parents=True, exist_ok=True)
    small = {n: a.dir / f"small-{n}.mcap" for n in (a.small, 2 * a.small)}
    for n, p in small.items():
        if not p.exists():
            make(p, n, 0.1, "none")
    big = a.big
    if big is None:
        big = a.dir / f"big-{a.frames}.mcap"
        make(big, a.frames, 0.1, "none")  # written now: fresh in the page cache
    n_big = (
        a.frames
        if a.big is None
        else int(
            _native.extract(
                str(big),
                thermrs.load_rig()._native,
                progress=None,
                min_sigma_px=None,
                threshold_sigma=None,
                verify_crc=False,
                content_hash=False,
            )[0]["t_ns"].shape[0]
        )
    )
    rig = thermrs.load_rig()._native

    def routes(path: Path) -> dict[str, Callable[[], object]]:
        def ex(check: bool) -> object:
            return _native.extract(
                str(path),
                rig,
                progress=None,
                min_sigma_px=None,
                threshold_sigma=None,
                verify_crc=check,
                content_hash=False,
            )

        return {
            "crc only": lambda: _native.checksum_chunks(str(path)),
            "core unchecked": lambda: ex(False),
            "core checked": lambda: ex(True),
        }

    buf = bytearray(16 << 20)

    def read() -> None:
        with open(big, "rb", buffering=0) as fh:
            while fh.readinto(buf):
                pass

    (n1, p1), (n2, p2) = sorted(small.items())
    rounds = []
    for r in range(a.rounds):
        row: dict[str, float] = {"read": _median(read, 5) / n_big * 1e6}
        for name, g in routes(big).items():
            if name != "core unchecked":
                row[f"{name} (file)"] = _median(g, 5) / n_big * 1e6
        r1, r2 = routes(p1), routes(p2)
        for name in r1:
            t1, t2 = _median(r1[name], 21), _median(r2[name], 21)
            row[f"{name} (in cache)"] = (t2 - t1) / (n2 - n1) * 1e6
        row["bound"] = row["read"] / max(row["crc only (file)"], row["core checked (in cache)"])
        row["now"] = row["read"] / row["core checked (file)"]
        rounds.append(row)
        print(f"round {r + 1}: " + ", ".join(f"{k} {v:.2f}" for k, v in row.items()), flush=True)
    print(f"{big.name}: {n_big} frames; µs per frame, medians of {a.rounds} rounds:")
    for k in rounds[0]:
        v = statistics.median(x[k] for x in rounds)
        unit = "× one read" if k in ("bound", "now") else "µs/frame"
        print(f"  {k:26s} {v:7.2f} {unit}")


if __name__ == "__main__":
    main()
