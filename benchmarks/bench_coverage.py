"""Coverage of the α estimators' 95 % intervals over seeded simulated runs with known α.

Each trial simulates one run of the paper rig (α = 23.2e-6/K) with every noise of the default
scenario (centroid shot/read noise, pose repeatability, IR pixel noise 0.05 K, ambient noise),
extracts it and fits α four ways:

- time-series, ROI peak: :func:`thermrs.fit.fit_alpha` on the default run table (de-noised
  ROI peaks);
- time-series, ROI max: the same on the ROI maxima (SPEC §3 reading);
- time-series, true temperatures: the same with the simulator's true surface temperatures
  (isolates the temperature reading from the estimator);
- start/end: the paper's estimator (:func:`thermrs.fit.fit_alpha_start_end`, mean of the
  cameras) on the default run table.

Reported per estimator: the share of trials whose interval holds the true α, the mean
interval width and the mean error.

Run:  python benchmarks/bench_coverage.py [--trials 100] [--speed 30] [--hours 6] [--cycle-s 180]
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--speed", type=float, default=30)
    ap.add_argument("--hours", type=float, default=6)
    ap.add_argument("--cycle-s", type=float, default=180)
    ap.add_argument("--out", type=Path, default=Path("bench-out/coverage.json"))
    args = ap.parse_args()
    rows: dict[str, list[tuple[float, float, float]]] = {}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        for k in range(args.trials):
            for name, v in trial(args.first_seed + k, args, Path(d)).items():
                rows.setdefault(name, []).append(v)
            dt = time.perf_counter() - t0
            print(f"trial {k + 1}/{args.trials} ({dt:.0f} s)", file=sys.stderr)
    print(
        f"{args.trials} trials: {args.hours:g} h at {args.speed:g} %, cycle {args.cycle_s:g} s, "
        f"true α {TRUE_ALPHA * 1e6:.2f}e-6/K\n"
    )
    print("| estimator | coverage of the 95 % interval | mean width (×10⁻⁶/K) | mean error (%) |")
    print("| --- | ---: | ---: | ---: |")
    doc = {}
    for name, v in rows.items():
        a = np.array(v)
        cover = float(np.mean((a[:, 1] <= TRUE_ALPHA) & (TRUE_ALPHA <= a[:, 2])))
        width = float(np.mean(a[:, 2] - a[:, 1]))
        err = float(np.mean(a[:, 0] / TRUE_ALPHA - 1) * 100)
        print(f"| {name} | {cover * 100:.1f} % | {width * 1e6:.3f} | {err:+.2f} |")
        doc[name] = {"coverage": cover, "mean_width": width, "mean_error_pct": err}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"trials": args.trials, "estimators": doc}, indent=2))


if __name__ == "__main__":
    main()
