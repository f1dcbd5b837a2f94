"""Backs the BENCHMARKS.md claim "campaign: tasks of several recordings on a quiet cluster".

What the campaign engine's two ways of cutting Dask's share each give, on 2 workers.

A campaign on a ``LocalCluster`` shares the machine's cores between the workers and the
client process (scheduler, nannies, client, commits). Two things cut what Dask takes:

- **tasks**: recordings handed out in tasks of consecutive recordings
  (:mod:`thermrs.campaigns.split`) instead of one task per recording;
- **quiet**: the cluster's background work turned down
  (:data:`thermrs.campaigns.engine.QUIET_CLUSTER`) instead of Dask's defaults.

This runs the four combinations in rounds (order alternating between rounds), each on a
fresh 2-worker cluster warmed by one campaign, timing two campaigns into new folders (their
mean) and the client process's CPU; it prints the medians and each variant's median paired
ratio to "neither". The engine is the landed one; "neither" and the single switches put back
one task per recording (``split`` replaced) and Dask's defaults (``QUIET_CLUSTER`` emptied).

Run: ``python benchmarks/bench_campaign_tasks.py --rounds 8`` (uses the recordings of
``bench_campaign.py``, made there first).
"""

from __future__ import annotations

import argparse
import itertools
import shutil
import statistics
from pathlib import Path

VARIANTS = {
    "neither": (False, False),
    "tasks": (True, False),
    "quiet": (False, True),
    "tasks+quiet": (True, True),
}


def _one_each(sizes: list[int], slots: int) -> list[list[int]]:
    return [[i] for i in range(len(sizes))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--recordings", type=int, default=24)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/campaign"))
    args = ap.parse_args()

    import thermrs
    from bench_campaign import timed_campaign
    from distributed import Client
    from thermrs.campaigns import engine

    recs = sorted((args.dir / "recs").glob("*.mcap"))[: args.recordings]
    if len(recs) < args.recordings:
        raise SystemExit(f"{args.dir}/recs: run benchmarks/bench_campaign.py first")
    out = args.dir / "tasks-ab"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    fresh = (out / f"{i}" for i in itertools.count())
    landed_split, landed_quiet = engine.split, dict(engine.QUIET_CLUSTER)
    wall: dict[str, list[float]] = {k: [] for k in VARIANTS}
    cpu: dict[str, list[float]] = {k: [] for k in VARIANTS}
    names = list(VARIANTS)
    try:
        for r in range(args.rounds):
            for name in names if r % 2 == 0 else names[::-1]:
                tasks, quiet = VARIANTS[name]
                engine.split = landed_split if tasks else _one_each  # type: ignore[assignment]
                engine.QUIET_CLUSTER.clear()
                engine.QUIET_CLUSTER.update(landed_quiet if quiet else {})
                with (
                    engine.local_cluster(2, silence_logs=50) as cluster,
                    Client(cluster) as client,  # type: ignore[no-untyped-call]
                ):
                    thermrs.campaign(recs, next(fresh), client=client)
                    runs = [timed_campaign(recs, next(fresh), client) for _ in range(2)]
                    engine.quiet_workers(client)
                wall[name].append(statistics.mean(w for w, _ in runs))
                cpu[name].append(statistics.mean(c for _, c in runs))
            print(
                f"round {r + 1}: "
                + "  ".join(f"{k} {wall[k][-1]:.3f} s ({cpu[k][-1]:.3f})" for k in names),
                flush=True,
            )
    finally:
        engine.split = landed_split  # type: ignore[assignment]
        engine.QUIET_CLUSTER.clear()
        engine.QUIET_CLUSTER.update(landed_quiet)
        shutil.rmtree(out, ignore_errors=True)
    print(f"{len(recs)} recordings, 2 workers, medians of {args.rounds} rounds:")
    for k in names:
        paired = statistics.median(b / a for a, b in zip(wall["neither"], wall[k], strict=True))
        print(
            f"  {k:12s} T2 {statistics.median(wall[k]):.3f} s  client CPU "
            f"{statistics.median(cpu[k]):.3f} s  paired to neither {paired:.3f}"
        )


if __name__ == "__main__":
    main()
