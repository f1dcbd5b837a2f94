"""A campaign of many recordings on a Dask ``LocalCluster``: 1 worker against 2, against the
sum of single-file extractions, and a re-run of the unchanged campaign.

Recordings: ``--recordings`` (default 24) simulated recordings of the embedded paper rig, two
runs of ``--minutes`` each (CCD frames at every visit, zstd), different seeds, written once
into ``--dir``.

Measured, in this order, with the page cache warm (every file read once first):
1. each recording extracted alone in this process (``thermrs.extract``, 1 rayon thread, tables
   in memory): their sum ``S``; and each through the same job as the campaign's, one file at a
   time in this process without a cluster (``thermrs.campaign([file], its own dataset)``: hash,
   extraction, Parquet partitions, catalog row): their sum ``Sf``, the single-file extractions
   the campaign's ``T2`` is held against (``T2 / (Sf/2)``);
2. the campaign on a fresh dataset with 1 worker process (``T1``) and with 2 (``T2``),
   each cluster started before the clock starts (worker start-up is reported apart);
3. the campaign again on the 2-worker dataset, nothing changed (``Tr``).
Each campaign is timed ``--repeats`` times (fresh dataset each time), median reported, and
the load average before and after.

Run:  python benchmarks/bench_campaign.py [--recordings 24] [--minutes 15] [--repeats 3]
      [--dir bench-out/campaign]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import time
from pathlib import Path

SCENARIO = """format = "thermrs-scenario/1"
seed = 1
[[run]]
name = "run1"
speed_pct = 30
duration_min = {m}
cycle_s = 60
start = "ambient"
[[run]]
name = "run2"
speed_pct = 75
duration_min = {m}
cycle_s = 60
start = "continue"
idle_before_min = 30
[camera]
mode = "visits"
frames_per_visit = 4
[output]
compression = "zstd"
"""


def make(d: Path, n: int, minutes: int) -> list[Path]:
    import thermrs
    from thermrs.simulate import simulate

    d.mkdir(parents=True, exist_ok=True)
    (d / "s.toml").write_text(SCENARIO.format(m=minutes))
    recs = []
    for i in range(n):
        p = d / "recs" / f"r{i:03d}.mcap"
        if not p.exists():
            p.parent.mkdir(exist_ok=True)
            simulate(thermrs.load_rig(), d / "s.toml", p, seed=i + 1)
        recs.append(p)
    return recs


def timed_campaign(recs: list[Path], out: Path, client: object) -> float:
    import thermrs

    t = time.perf_counter()
    thermrs.campaign(recs, out, client=client)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=24)
    ap.add_argument("--minutes", type=int, default=15)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/campaign"))
    args = ap.parse_args()
    os.environ.setdefault("RAYON_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import thermrs
    from distributed import Client, LocalCluster

    recs = make(args.dir, args.recordings, args.minutes)
    size = sum(p.stat().st_size for p in recs)
    for p in recs:
        p.read_bytes()
    print(f"{len(recs)} recordings, {size / 1e6:,.0f} MB; load average {os.getloadavg()[0]:.2f}")
    rig = thermrs.load_rig()
    singles = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        for p in recs:
            thermrs.extract(p, rig)
        singles.append(time.perf_counter() - t)
    s = statistics.median(singles)
    print(f"sum of in-memory extractions S = {s:.2f} s (median of {args.repeats})")
    # The same job as the campaign's, one file at a time in this process (no cluster): hash,
    # extract, write its partitions and catalog row into a dataset of its own.
    files = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        for i, p in enumerate(recs):
            out = args.dir / "single" / f"ds-{i}"
            shutil.rmtree(out, ignore_errors=True)
            out.parent.mkdir(parents=True, exist_ok=True)
            thermrs.campaign([p], out)
        files.append(time.perf_counter() - t)
    sf = statistics.median(files)
    print(f"sum of single-file extractions into datasets Sf = {sf:.2f} s (median)")
    res: dict[int, float] = {}
    for n in (1, 2):
        t = time.perf_counter()
        with (
            LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                env={"RAYON_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"},
            ) as cluster,
            Client(cluster) as client,
        ):
            print(f"{n} worker(s): cluster up in {time.perf_counter() - t:.1f} s")
            times = []
            for _ in range(args.repeats):
                out = args.dir / f"ds-{n}"
                shutil.rmtree(out, ignore_errors=True)
                times.append(timed_campaign(recs, out, client))
            res[n] = statistics.median(times)
            print(
                f"  campaign T{n} = {res[n]:.2f} s (runs: {', '.join(f'{x:.2f}' for x in times)})"
            )
            if n == 2:
                rerun = [timed_campaign(recs, out, client) for _ in range(args.repeats)]
                r = statistics.median(rerun)
                print(f"  unchanged re-run Tr = {r:.3f} s = {100 * r / res[2]:.1f} % of T2")
    print(
        f"T1/T2 = {res[1] / res[2]:.2f}x; T2 / (Sf/2) = {res[2] / (sf / 2):.2f}; "
        f"T2 / (S/2) = {res[2] / (s / 2):.2f}; T1 / Sf = {res[1] / sf:.2f}; "
        f"load average {os.getloadavg()[0]:.2f}"
    )


if __name__ == "__main__":
    main()
