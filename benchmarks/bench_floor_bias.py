"""Backs the BENCHMARKS.md row "the floor on the nominal residual with an effect present"
(issue #45).

The first step's tests compare the nominal model's held-out residual with the noise floor
estimated on that residual: with an effect in it, the floor must still be the noise's, not
the effect's slow structure read as noise. For each effect of ``--effect`` at each SNR of
``--snr``, in white and AR(1) worlds (a bench case drawn from its seed, as
``thermrs diagnose-bench`` draws it: :func:`thermrs.bench.world.cases.make_case`, 2 µm of
visit noise), and for ``--nulls`` effect-free worlds of each, the held-out floor
(:func:`thermrs.diagnose.noise_floor_um`) against the world's 2 µm. Printed: per case the
floor, then the mean, rms error and range with and without an effect.

    python benchmarks/bench_floor_bias.py --seed 5800000
"""

from __future__ import annotations

import argparse
import json

import numpy as np

EFFECTS = (
    "alpha_per_link",
    "thermal_lag",
    "fixture_drift",
    "sensor_drift",
    "joint_offset",
    "unmodelled_length",
    "nonlinear_alpha",
)


def main() -> None:
    import thermrs
    from thermrs.bench.world.cases import make_case
    from thermrs.bench.world.world import Campaign
    from thermrs.diagnose import noise_floor_um
    from thermrs.rig import load_rig

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effect", nargs="+", default=list(EFFECTS))
    ap.add_argument("--snr", nargs="+", type=float, default=[1.0, 2.0, 4.0])
    ap.add_argument("--nulls", type=int, default=2)
    ap.add_argument("--hours", type=float, default=15.0)
    ap.add_argument("--seed", type=int, default=5800000)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    path = str(thermrs.rig.default_rig_path())
    rig = load_rig(path)
    cases = [("none", 0.0)] * a.nulls + [(e, s) for e in a.effect for s in a.snr]
    rows = []
    for world in ("white", "ar1"):
        for i, (eff, snr) in enumerate(cases):
            seed = a.seed + 1000 * (world == "ar1") + i
            tables, _, _ = make_case(
                path,
                () if eff == "none" else (eff,),
                snr,
                world=world,
                seed=seed,
                campaign=Campaign(hours=a.hours),
            )
            fl = noise_floor_um(tables[:1], tables[1:], rig)
            rows.append({"world": world, "effect": eff, "snr": snr, "seed": seed, "floor_um": fl})
            print(f"{world:5} {eff:18} SNR {snr:3.1f} seed {seed}: floor {fl:.3f} µm", flush=True)
    for label, pick in (("with an effect", True), ("effect-free", False)):
        f = np.array([r["floor_um"] for r in rows if (r["effect"] != "none") == pick])
        if len(f):
            print(
                f"{label}: {len(f)} cases, mean {f.mean():.3f} µm, rms error "
                f"{np.sqrt(np.mean((f - 2.0) ** 2)):.3f} µm, range {f.min():.2f}–{f.max():.2f} µm"
            )
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
