"""Backs the BENCHMARKS.md claim "batch forward kinematics against the Robotics Toolbox".

Batch forward-kinematics throughput: thermrs vs the Robotics Toolbox, in one run.

Both compute the flange transform of the paper rig's KR 15/2 DH chain for random joint
vectors; thermrs also applies per-sample thermal expansion (two temperature columns), which
the toolbox cannot. Each thermrs thread count runs in its own process (rayon's pool size is
fixed at start-up). Results are printed as a Markdown table and written to
``bench-out/fk.json``.

Run:  python benchmarks/bench_fk.py  [--n 2000000] [--rtb-n 20000]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def best_of(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def run_thermrs(n: int, what: str) -> float:
    import thermrs

    rig = thermrs.load_rig()
    m = thermrs.ForwardModel(rig)
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (n, 6))
    temps = {"link2": rng.uniform(20, 40, n), "link3": rng.uniform(20, 40, n)}
    if what == "transforms":
        dt = best_of(lambda: m.flange_transforms(q, temperatures=temps), 3)
    else:
        dt = best_of(lambda: m.spots("A", q, temperatures=temps), 3)
    return n / dt


def run_rtb(n: int) -> float:
    import roboticstoolbox as rtb
    import thermrs

    rig = thermrs.load_rig()
    robot = rtb.DHRobot(
        [
            rtb.RevoluteDH(
                a=r.a_mm,
                alpha=np.radians(r.alpha_deg),
                d=r.d_mm,
                offset=np.radians(r.theta_offset_deg),
                flip=r.sign == -1,
            )
            for r in rig.dh
        ]
    )
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (n, 6))
    return n / best_of(lambda: robot.fkine(q), 3)


def numpy_fk(rows: list, q: np.ndarray) -> np.ndarray:
    """Vectorised standard DH in numpy: the route a user might write by hand."""
    n = q.shape[0]
    t = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    for i, r in enumerate(rows):
        th = r.sign * q[:, i] + np.radians(r.theta_offset_deg)
        ct, st = np.cos(th), np.sin(th)
        ca, sa = np.cos(np.radians(r.alpha_deg)), np.sin(np.radians(r.alpha_deg))
        a = np.zeros((n, 4, 4))
        a[:, 0, 0], a[:, 0, 1], a[:, 0, 2], a[:, 0, 3] = ct, -st * ca, st * sa, r.a_mm * ct
        a[:, 1, 0], a[:, 1, 1], a[:, 1, 2], a[:, 1, 3] = st, ct * ca, -ct * sa, r.a_mm * st
        a[:, 2, 1], a[:, 2, 2], a[:, 2, 3] = sa, ca, r.d_mm
        a[:, 3, 3] = 1.0
        t = t @ a
    return t


def run_numpy(n: int) -> float:
    import thermrs

    rows = thermrs.load_rig().dh
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (n, 6))
    return n / best_of(lambda: numpy_fk(rows, q), 3)


def child(args: argparse.Namespace) -> None:
    if args.child == "rtb":
        rate = run_rtb(args.rtb_n)
    elif args.child == "numpy":
        rate = run_numpy(args.n // 4)
    else:
        rate = run_thermrs(args.n, args.child)
    print(json.dumps({"rate": rate}))


def spawn(kind: str, threads: int, args: argparse.Namespace) -> float:
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads))
    cmd = [
        sys.executable,
        __file__,
        "--child",
        kind,
        "--n",
        str(args.n),
        "--rtb-n",
        str(args.rtb_n),
    ]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    return float(json.loads(p.stdout.strip().splitlines()[-1])["rate"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2_000_000, help="samples per thermrs call")
    ap.add_argument("--rtb-n", type=int, default=20_000, help="samples per toolbox call")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return
    rtb_rate = spawn("rtb", 1, args)
    rows = [
        ("Robotics Toolbox 1.x `DHRobot.fkine` (4×4, no expansion)", 1, rtb_rate),
        ("numpy, vectorised DH by hand (4×4, no expansion)", 1, spawn("numpy", 1, args)),
    ]
    for threads in (1, 2):
        rows.append(
            (
                "thermrs `flange_transforms` (4×4, with expansion)",
                threads,
                spawn("transforms", threads, args),
            )
        )
        rows.append(
            (
                "thermrs `spots` (FK + laser ray + chip, with expansion)",
                threads,
                spawn("spots", threads, args),
            )
        )
    print(
        f"\nBatch FK on {platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}"
    )
    print(f"thermrs: {args.n:,} poses per call; toolbox: {args.rtb_n:,}; best of 3\n")
    print("| route | threads | poses/s | × toolbox |")
    print("| --- | ---: | ---: | ---: |")
    for name, threads, rate in rows:
        print(f"| {name} | {threads} | {rate:,.0f} | {rate / rtb_rate:,.0f}× |")
    out = Path("bench-out")
    out.mkdir(exist_ok=True)
    (out / "fk.json").write_text(
        json.dumps([{"route": n, "threads": t, "poses_per_s": r} for n, t, r in rows], indent=2)
    )


if __name__ == "__main__":
    main()
