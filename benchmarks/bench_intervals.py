"""Backs the BENCHMARKS.md rows "coverage of every printed interval" (issue #45).

Each case: the independent bench world (:mod:`thermrs.bench.world`: its own
kinematics, thermal network, instruments and effects) renders three runs with one effect at a
target SNR, on seeds from ``--first-seed`` (never the seeds 1000–4999 the diagnoser's rules
were chosen on). The runs are diagnosed as ``thermrs diagnose`` does, and every interval the
diagnosis prints is checked against the world's truth, which the code under test did not
produce:

- the noise floor's 95 % interval against the world's visit repeatability σ (every case), and
  that of its chips' and poses' part (the thermal camera's reading noise through the model
  taken out: ``noise_floor.thermometers.chips_ci95``), which is what the world's σ is;
- each parameter of the true effect in the verdict's ``params_ci95`` against its true value
  (cases whose verdict names the true effect alone; a vector parameter counts per entry);
  where the verdict names another of the effect's discrete choices (joint, temperature,
  length, camera), the interval of the true choice's joint fit if it is among the
  alternatives the data cannot reject (``params_alternatives_fitted``, what the user reads),
  else a miss;
- α with the effect (``verdict.alpha_ci95``, the joint fit) against the world's α per
  *measured* kelvin: its true α over the IR camera's mean gain on the links (the coefficient a
  law applied to measured temperatures needs);
- the compensation law's coefficients (µm/K per measured temperature, every law) against
  the same slopes of the world's true rig at that α with the world's effect at its true
  parameters, computed with the world's own kinematics
  (:func:`thermrs.bench.world.world.measured_slopes`); the median half-width of a law's
  coefficients of at least 0.5 µm/K.

Coverage is counted per parameter with an exact (Clopper–Pearson) 95 % interval.

    python benchmarks/bench_intervals.py --effect thermal_lag sensor_drift joint_offset \
        --seeds 6 --snr 2 --hours 15 --first-seed 900000 --jobs 2
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np


def _covers(ci: Any, truth: Any) -> list[bool]:
    """Whether each entry of ``truth`` lies in its interval (scalar, list or dict)."""
    if isinstance(truth, dict):
        out = []
        for k, v in truth.items():
            if isinstance(ci, dict) and k in ci:
                out += _covers(ci[k], v)
        return out
    if isinstance(truth, list | tuple):
        return [bool(c[0] <= t <= c[1]) for c, t in zip(ci, truth, strict=False) if c is not None]
    return [bool(ci[0] <= truth <= ci[1])]


def one(args: tuple[str, str, int, float, float]) -> dict[str, Any]:
    import thermrs
    from thermrs.bench.world.cases import case_rigs, case_truths
    from thermrs.bench.world.world import (
        Campaign,
        closest_first_order_tau,
        draw_scene,
        measured_slopes,
        render,
    )
    from thermrs.compensate import compensation_law, diagnosed_model
    from thermrs.diagnose import diagnose

    effect, world, seed, snr, hours = args
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    scene = draw_scene(wrig, Campaign(hours=hours), world, seed, tolerances=rig.tolerances)
    truths, reached, _ = case_truths(wrig, scene, (effect,), snr, seed)
    tables = render(scene, tuple(truths))
    doc = diagnose(tables[:1], tables[1:], rig, seed=seed, bootstrap=0).to_json()
    v = doc["verdict"]
    injected = truths[0].spec(scene.alpha_per_k)
    gain = float(np.mean(list(scene.ir_gain.values())))
    alpha_meas = scene.alpha_per_k / gain
    chips = (doc["noise_floor"].get("thermometers") or {}).get("chips_ci95")
    row: dict[str, Any] = {
        "effect": effect,
        "world": world,
        "seed": seed,
        "snr": reached[0],
        "status": v["outcome"],
        "named": v["effects"],
        "floor_covers": bool(
            doc["noise_floor"]["holdout_ci95"][0]
            <= scene.campaign.sigma_um
            <= doc["noise_floor"]["holdout_ci95"][1]
        ),
        "floor_um": doc["noise_floor_um"],
        # The chips' and poses' part of it (the thermal camera's reading noise through the
        # model taken out): the world's σ is that part alone.
        "chips_covers": None
        if not chips
        else bool(chips[0] <= scene.campaign.sigma_um <= chips[1]),
        "thermometers_um": (doc["noise_floor"].get("thermometers") or {}).get("thermometers_um"),
        "injected": injected,
        "lags_min": [list(x) for x in truths[0].lags()],
        "params": v.get("params"),
        "params_ci95": v.get("params_ci95"),
        "alpha_truth_per_measured_k": alpha_meas,
        "alpha_ci95": v.get("alpha_ci95"),
    }
    if v["status"] != "identified" or v["effects"] != [effect]:
        return row
    truth = {k: x for k, x in injected.items() if k != "name" and isinstance(x, int | float | list)}
    if isinstance(injected.get("alpha_per_k"), dict):
        truth["alpha_per_k"] = injected["alpha_per_k"]
    # The effect's discrete choice (joint, temperature, length, camera): the one named, one
    # of its alternatives the data cannot reject (whose joint fit the user reads in
    # `params_alternatives_fitted`), or rejected (no interval the user reads holds the truth).
    choice = {k: x for k, x in injected.items() if k != "name" and isinstance(x, str)}
    fit = {"params_ci95": v.get("params_ci95") or {}, "alpha_ci95": v.get("alpha_ci95")}
    row["choice"] = "named"
    if any(v["params"].get(k) != x for k, x in choice.items()):
        row["choice"] = "rejected"
        for alt in v.get("params_alternatives_fitted") or []:
            if all(alt["params"].get(k) == x for k, x in choice.items()):
                row["choice"], fit = "kept", alt
    cover: dict[str, list[bool]] = {}
    for k, x in truth.items():
        ci = (fit.get("params_ci95") or {}).get(k)
        if row["choice"] == "rejected":
            cover[k] = [False] * len(_covers((v.get("params_ci95") or {}).get(k, [0, 0]), x))
        elif ci is not None:
            cover[k] = _covers(ci, x)
    if effect == "thermal_lag" and "tau_min" in (v.get("params_ci95") or {}):
        # A two-time-constant lag against the first-order lag closest to it (what a
        # first-order model estimates), beside its weighted mean time constant above.
        tau_eq = closest_first_order_tau(scene, truths[0])
        row["tau_closest_first_order_min"] = tau_eq
        cover["tau_min (closest first-order lag)"] = _covers(v["params_ci95"]["tau_min"], tau_eq)
    if fit.get("alpha_ci95"):
        hit = _covers(fit["alpha_ci95"], alpha_meas)
        cover["alpha (joint fit)"] = [False] if row["choice"] == "rejected" else hit
    row["covers"] = cover
    row["half_width"] = {
        k: float((c[1] - c[0]) / 2 / abs(v["params"][k]))
        for k, c in (v.get("params_ci95") or {}).items()
        if isinstance(v["params"].get(k), int | float) and v["params"][k]
    }
    law = compensation_law(rig, diagnosed_model(doc, rig))
    slopes = measured_slopes(scene, scene.alpha_per_k, effects=truths)
    hits, widths = [], []
    for r in law.table.iter_rows(named=True):
        name = str(r["term"]).split(" ")[0]
        key = (str(r["camera"]), name)
        if key not in slopes or not str(r["term"]).endswith("(T - reference_c)"):
            continue
        t = float(slopes[key][0 if r["axis"] == "u" else 1])
        hits.append(bool(r["ci95_low"] <= t <= r["ci95_high"]))
        if abs(t) >= 0.5:  # the relative width of a slope of almost nothing says nothing
            widths.append((r["ci95_high"] - r["ci95_low"]) / 2 / abs(r["coefficient"]))
    row["law_covers"] = hits
    row["law_half_width_median"] = float(np.median(widths)) if widths else None
    return row


def _cp(k: int, n: int) -> str:
    from scipy.stats import beta

    lo = beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return f"{k}/{n} ({lo:.0%}–{hi:.0%})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effect", nargs="+", default=["thermal_lag", "sensor_drift"])
    ap.add_argument("--world", nargs="+", default=["white", "ar1"])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--first-seed", type=int, default=900000)
    ap.add_argument("--snr", type=float, default=2.0)
    ap.add_argument("--hours", type=float, default=15.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    todo = [
        (e, w, a.first_seed + 1000 * i + k, a.snr, a.hours)
        for i in range(a.seeds)
        for k, (e, w) in enumerate((e, w) for e in a.effect for w in a.world)
    ]
    with ProcessPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(one, todo))
    floor = [r["floor_covers"] for r in rows]
    print(f"noise floor's interval covers σ: {_cp(sum(floor), len(floor))}")
    chips = [r["chips_covers"] for r in rows if r["chips_covers"] is not None]
    print(f"its chips' and poses' part's interval covers σ: {_cp(sum(chips), len(chips))}")
    by: dict[str, list[bool]] = {}
    for r in rows:
        for k, hits in (r.get("covers") or {}).items():
            by.setdefault(f"{r['effect']}: {k}", []).extend(hits)
        if r.get("law_covers"):
            by.setdefault(f"{r['effect']}: law µm/K coefficients", []).extend(r["law_covers"])
    for k, hits in sorted(by.items()):
        print(f"{k}: covers the truth {_cp(sum(hits), len(hits))}")
    for e in a.effect:
        here = [r for r in rows if r["effect"] == e]
        named = [r for r in here if "covers" in r]
        print(f"{e}: identified alone in {len(named)}/{len(here)}")
        ch = [r["choice"] for r in named]
        if any(c != "named" for c in ch):
            print(f"{e}: its true choice named {ch.count('named')}, kept among the "
                  f"alternatives {ch.count('kept')}, rejected {ch.count('rejected')}")  # fmt: skip
        hw = [r["law_half_width_median"] for r in named if r.get("law_half_width_median")]
        if hw:
            print(f"{e}: law coefficients' median half-width {np.median(hw):.0%} (per law: "
                  + ", ".join(f"{x:.0%}" for x in hw) + ")")  # fmt: skip
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1, default=float)


if __name__ == "__main__":
    main()
