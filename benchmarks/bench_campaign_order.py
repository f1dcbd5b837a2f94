"""Backs the BENCHMARKS.md claim "campaign: largest recording first".

A campaign whose one long recording is listed last: largest first (what thermrs does)
against the listing's order, on a 2-worker LocalCluster.

Recordings: the first ``--small`` recordings of ``bench_campaign.py``'s short set
(``--dir``/recs) and one of its 60-minute set (``--long-dir``/recs), listed in that order;
run ``bench_campaign.py`` (and with ``--minutes 60 --dir bench-out/campaign60``) first to
write them. "Listing order" is :func:`thermrs.campaigns.engine.campaign` with its one line that
sorts the recordings largest first removed (its source loaded with that line taken out), so
that nothing else differs. The two run alternately on the same cluster, warmed first; prints
each time and the medians.

Run:  python benchmarks/bench_campaign_order.py [--small 23] [--repeats 4]
      [--dir bench-out/campaign] [--long-dir bench-out/campaign60]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import time
import types
from pathlib import Path
from typing import Any

SORT_LINE = "    todo.sort(key=lambda s: s.size_bytes, reverse=True)\n"


def listing_order_campaign() -> Any:
    """``campaign`` as thermrs has it, less the sort: recordings go out in the listing's order."""
    import thermrs.campaigns.engine as eng

    src = Path(eng.__file__).read_text(encoding="utf-8")
    if SORT_LINE not in src:
        raise SystemExit("the engine no longer has the sort line this benchmark removes")
    mod = types.ModuleType("listing_order_engine")
    mod.__file__ = eng.__file__
    sys.modules[mod.__name__] = mod
    exec(compile(src.replace(SORT_LINE, ""), mod.__name__, "exec"), mod.__dict__)
    return mod.campaign


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", type=int, default=23)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/campaign"))
    ap.add_argument("--long-dir", type=Path, default=Path("bench-out/campaign60"))
    args = ap.parse_args()
    for k in ("RAYON_NUM_THREADS", "POLARS_MAX_THREADS", "OMP_NUM_THREADS"):
        os.environ[k] = "1"
    import thermrs.campaigns.engine as eng
    from distributed import Client

    small = sorted((args.dir / "recs").glob("r*.mcap"))[: args.small]
    long = sorted((args.long_dir / "recs").glob("r*.mcap"))[:1]
    if len(small) < args.small or not long:
        raise SystemExit("write the recordings first with bench_campaign.py (see the docstring)")
    recs = small + long
    for p in recs:
        p.read_bytes()
    mb = [sum(p.stat().st_size for p in g) / 1e6 for g in (small, long)]
    print(f"{len(small)} short recordings ({mb[0]:,.0f} MB), then 1 long ({mb[1]:,.0f} MB)")
    routes = {"largest first": eng.campaign, "listing order": listing_order_campaign()}
    times: dict[str, list[float]] = {k: [] for k in routes}
    out = args.dir / "order"
    with eng.local_cluster(2) as cluster, Client(cluster) as client:
        shutil.rmtree(out, ignore_errors=True)
        eng.campaign(recs, out, client=client)  # warm the workers
        names = list(routes)
        for i in range(args.repeats):
            for name in names if i % 2 == 0 else names[::-1]:
                shutil.rmtree(out, ignore_errors=True)
                t = time.perf_counter()
                routes[name](recs, out, client=client)
                times[name].append(time.perf_counter() - t)
    for name, ts in times.items():
        print(
            f"{name}: median {statistics.median(ts):.2f} s (runs: "
            + ", ".join(f"{x:.2f}" for x in ts)
            + ")"
        )


if __name__ == "__main__":
    main()
