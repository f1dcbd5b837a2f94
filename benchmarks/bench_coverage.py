"""Backs the BENCHMARKS.md claim "α's 95 % interval honest on three geometries".

Coverage of the α estimators' 95 % intervals with known α, on several rig geometries.

Synthetic visit series (default): on the paper rig, the UR5 fixture and random KR 16-like
rigs (tests/coverage.py: chips placed in the laser's path by the Robotics Toolbox), spots
from the forward model at a random true α (15–25×10⁻⁶/K) along first-order warm-ups of
every mapped temperature, two 6-hour runs per trial, a visit per camera every 2 min, unknown
offsets per run and camera, and visit errors AR(1) along each chip axis (ρ 0.3–0.9), u–v
correlated (0.3–0.7), 1–3 µm. The time-series fit (:func:`thermrs.fit.fit_alpha`) on the
true temperatures; reported per rig: the share of trials whose interval holds the true α, the
mean half-width over 1.96 × the true spread (std of α̂ − α over trials; 1 = honest), the
mean effective number of visits; beside them the same least squares with the iid interval,
and the estimator before issue #9 (pinv of the normal matrix at numpy's default cutoff).

Full simulations (``--full-trials N``): each trial simulates a run of the paper rig with every
noise of the default scenario, extracts it and fits α four ways (time-series on ROI peaks,
on ROI maxima, on the true temperatures; the paper's start/end estimator).

Run:  python benchmarks/bench_coverage.py [--trials 400] [--random-rigs 40]
          [--full-trials 0] [--speed 30] [--hours 6] [--cycle-s 180]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import polars as pl

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

TRUE_ALPHA = 23.2e-6

SCENARIO = """format = "thermrs-scenario/1"
seed = {seed}
[[run]]
name = "run"
speed_pct = {speed}
duration_min = {minutes}
cycle_s = {cycle_s}
start = "ambient"
"""


def trial(seed: int, args: argparse.Namespace, tmp: Path) -> dict[str, tuple[float, float, float]]:
    """One seeded run: estimator → (α, low, high)."""
    import thermrs
    from thermrs.fit import fit_alpha, fit_alpha_start_end, interpolate, run_table
    from thermrs.simulate import simulate

    rig = thermrs.load_rig()
    sc = tmp / f"s{seed}.toml"
    sc.write_text(
        SCENARIO.format(
            seed=seed, speed=args.speed, minutes=int(args.hours * 60), cycle_s=args.cycle_s
        )
    )
    sim = simulate(rig, sc, tmp / f"s{seed}.mcap")
    ex = thermrs.extract(sim.recording, rig)
    out: dict[str, tuple[float, float, float]] = {}
    peak = run_table(ex, rig)
    f = fit_alpha([peak], rig)
    out["time-series, ROI peak"] = (f.alpha_per_k, *f.ci95)
    f = fit_alpha([run_table(ex, rig, temperature="max")], rig)
    out["time-series, ROI max"] = (f.alpha_per_k, *f.ci95)
    s = sim.samples.sort("t_ns")
    st = s["t_ns"].to_numpy().astype(float)
    t = peak["t_ns"].to_numpy().astype(float)
    true_t = peak.with_columns(
        **{
            f"{n}_c": pl.Series(interpolate(t, st, s[f"{n}_surface_c"].to_numpy()))
            for n in ("link2", "link3")
        }
    )
    f = fit_alpha([true_t], rig)
    out["time-series, true temperatures"] = (f.alpha_per_k, *f.ci95)
    se = fit_alpha_start_end(peak, rig)
    out["start/end (mean of cameras), ROI peak"] = (se.mean[0], *se.mean[1])
    for p in tmp.glob(f"s{seed}*"):
        p.unlink()
    return out


def before_issue9(tables: list[pl.DataFrame], rig: object) -> tuple[float, float, float]:
    """α and its 95 % interval as thermrs computed them before issue #9: weighted least
    squares, covariance pinv(XᵀWX) at numpy's default cutoff, Student-t on iid residuals."""
    from scipy import stats
    from thermrs.fit import alpha_design

    table = pl.concat(tables, how="diagonal_relaxed")
    d = alpha_design(table, rig)  # type: ignore[arg-type]
    assert d.ok.all()  # finite visits: the same rows as the design of old
    x, y = d.x, d.y
    dof = len(y) - x.shape[1]
    beta, *_ = np.linalg.lstsq(x, y, rcond=None)
    r = y - x @ beta
    cams = table["camera"].to_list()
    grp = np.array([f"{c}/u" for c in cams] + [f"{c}/v" for c in cams])
    sd = np.empty(len(y))
    for gname in set(grp.tolist()):
        m = grp == gname
        sd[m] = np.sqrt(np.mean(r[m] ** 2))
    xw, yw = x / sd[:, None], y / sd
    beta, *_ = np.linalg.lstsq(xw, yw, rcond=None)
    rw = yw - xw @ beta
    cov = float(rw @ rw) / dof * np.linalg.pinv(xw.T @ xw)
    half = float(stats.t.ppf(0.975, dof) * np.sqrt(cov[0, 0]))
    return float(beta[0]), float(beta[0]) - half, float(beta[0]) + half


def synthetic(args: argparse.Namespace) -> list[dict[str, object]]:
    """The coverage table of the synthetic visit series, one row per geometry."""
    from thermrs.fit import fit_alpha
    from thermrs.stats import lstsq_qr

    from tests.support.coverage import geometries, random_rig, visit_tables

    rng = np.random.default_rng(args.first_seed)
    rigs: dict[str, list[object]] = {k: [v] for k, v in geometries().items()}
    rigs[f"random KR 16-like rigs ({args.random_rigs})"] = [
        random_rig(rng) for _ in range(args.random_rigs)
    ]
    rows = []
    for name, pool in rigs.items():
        per_rig = max(1, args.trials // len(pool))
        res = []
        t0 = time.perf_counter()
        for rig in pool:
            for _ in range(per_rig):
                alpha = rng.uniform(15e-6, 25e-6)
                tables = visit_tables(rig, rng, alpha=alpha)  # type: ignore[arg-type]
                f = fit_alpha(tables, rig)  # type: ignore[arg-type]
                # The same least squares, iid interval (rows independent).
                from thermrs.fit import alpha_design

                d = alpha_design(pl.concat(tables), rig)  # type: ignore[arg-type]
                iid = lstsq_qr(d.x, d.y).interval(0)
                old = before_issue9(tables, rig)
                res.append((alpha, f.alpha_per_k, *f.ci95, f.n_eff, *iid, *old))
        a = np.array(res)
        err = a[:, 1] - a[:, 0]
        spread = 1.96 * float(np.std(err))

        def cover(lo: np.ndarray, hi: np.ndarray, a: np.ndarray = a) -> float:
            return float(np.mean((lo <= a[:, 0]) & (a[:, 0] <= hi)))

        old_err = a[:, 7] - a[:, 0]
        rows.append(
            {
                "geometry": name,
                "trials": len(a),
                "coverage": cover(a[:, 2], a[:, 3]),
                "width_ratio": float(np.mean((a[:, 3] - a[:, 2]) / 2)) / spread,
                "n_eff": float(np.mean(a[:, 4])),
                "n_visits": int(sum(t.height for t in tables)),
                "iid_coverage": cover(a[:, 5], a[:, 6]),
                "iid_width_ratio": float(np.mean((a[:, 6] - a[:, 5]) / 2)) / spread,
                "before_coverage": cover(a[:, 8], a[:, 9]),
                "before_width_ratio": float(np.mean((a[:, 9] - a[:, 8]) / 2))
                / (1.96 * float(np.std(old_err))),
                "seconds": time.perf_counter() - t0,
            }
        )
        print(f"{name}: {len(a)} trials in {rows[-1]['seconds']:.0f} s", file=sys.stderr)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=400, help="synthetic trials per geometry")
    ap.add_argument("--random-rigs", type=int, default=40)
    ap.add_argument("--full-trials", type=int, default=0, help="full simulator trials")
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--speed", type=float, default=30)
    ap.add_argument("--hours", type=float, default=6)
    ap.add_argument("--cycle-s", type=float, default=180)
    ap.add_argument("--out", type=Path, default=Path("bench-out/coverage.json"))
    args = ap.parse_args()
    syn = synthetic(args) if args.trials > 0 else []
    print(
        "| geometry | trials | coverage of the 95 % interval | half-width / (1.96 × true "
        "spread) | mean n_eff (of visits) | iid interval: coverage, width | before #9: "
        "coverage, width |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in syn:
        print(
            f"| {r['geometry']} | {r['trials']} | {r['coverage'] * 100:.1f} % | "
            f"{r['width_ratio']:.2f} | {r['n_eff']:.0f} of {r['n_visits']} | "
            f"{r['iid_coverage'] * 100:.1f} %, {r['iid_width_ratio']:.2f} | "
            f"{r['before_coverage'] * 100:.1f} %, {r['before_width_ratio']:.2f} |"
        )
    doc: dict[str, object] = {"synthetic": syn}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=2))
    if args.full_trials <= 0:
        return
    rows: dict[str, list[tuple[float, float, float]]] = {}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        for k in range(args.full_trials):
            for name, v in trial(args.first_seed + k, args, Path(d)).items():
                rows.setdefault(name, []).append(v)
            dt = time.perf_counter() - t0
            print(f"trial {k + 1}/{args.full_trials} ({dt:.0f} s)", file=sys.stderr)
    print(
        f"\n{args.full_trials} full trials: {args.hours:g} h at {args.speed:g} %, cycle "
        f"{args.cycle_s:g} s, true α {TRUE_ALPHA * 1e6:.2f}e-6/K\n"
    )
    print("| estimator | coverage of the 95 % interval | mean width (×10⁻⁶/K) | mean error (%) |")
    print("| --- | ---: | ---: | ---: |")
    full = {}
    for name, v in rows.items():
        a = np.array(v)
        cover = float(np.mean((a[:, 1] <= TRUE_ALPHA) & (TRUE_ALPHA <= a[:, 2])))
        width = float(np.mean(a[:, 2] - a[:, 1]))
        err = float(np.mean(a[:, 0] / TRUE_ALPHA - 1) * 100)
        print(f"| {name} | {cover * 100:.1f} % | {width * 1e6:.3f} | {err:+.2f} |")
        full[name] = {"coverage": cover, "mean_width": width, "mean_error_pct": err}
    doc["full"] = {"trials": args.full_trials, "estimators": full}
    args.out.write_text(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
