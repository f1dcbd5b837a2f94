"""Backs the BENCHMARKS.md row "a compensation law is the model the diagnosis fitted".

A diagnosis reports the held-out rms its model leaves (``how_far.holdout_rms_after_um``); the
law exported from it (:func:`thermrs.compensate.compensation_law`), applied to the same
held-out runs (:meth:`~thermrs.compensate.CompensationLaw.check`), must leave the same. For a
thermal lag in the independent bench world (two time constants, of which a first-order lag
fits only a share), each seed's case at SNR 2 in white and AR(1) worlds is diagnosed and the
law checked; printed beside it, the same law with all of the expansion lagging (the law before
the lag carried its share).

    python benchmarks/bench_law_fidelity.py --first-seed 6200 --seeds 4
"""

from __future__ import annotations

import argparse
import dataclasses


def main() -> None:
    import thermrs
    from thermrs.bench.world.cases import case_rigs, case_truths
    from thermrs.bench.world.world import Campaign, draw_scene, render
    from thermrs.compensate import compensation_law, diagnosed_model
    from thermrs.diagnose import diagnose
    from thermrs.effects import ThermalLag

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--first-seed", type=int, default=6200)
    ap.add_argument("--seeds", type=int, default=4)
    args = ap.parse_args()
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    errs: list[float] = []
    for world in ("white", "ar1"):
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            scene = draw_scene(wrig, Campaign(), world, seed, tolerances=rig.tolerances)
            truths, _, _ = case_truths(wrig, scene, ("thermal_lag",), 2.0, seed)
            tables = render(scene, tuple(truths))
            doc = diagnose(tables[:1], tables[1:], rig, seed=seed, bootstrap=0).to_json()
            v = doc["verdict"]
            if v["effect"] != "thermal_lag" or v["status"] not in ("identified", "ambiguous"):
                print(f"{world} {seed}: {v['status']} {v['effect']}: no lag law")
                continue
            model = diagnosed_model(doc, rig)
            law = compensation_law(rig, model).check(tables[1:], rig)["all"]
            full = dataclasses.replace(model, effects=(ThermalLag(tau_min=v["params"]["tau_min"]),))
            whole = compensation_law(rig, full).check(tables[1:], rig)["all"]
            after = doc["how_far"]["holdout_rms_after_um"]
            got, old = law["compensated_rms_um"], whole["compensated_rms_um"]
            errs.append(got / after - 1.0)
            print(
                f"{world} {seed}: share {v['params'].get('weight', 1.0):.3f}; the diagnosis "
                f"{after:.3f} µm, the law {got:.3f} ({got / after - 1:+.1%}), all lagging "
                f"{old:.3f} ({old / after - 1:+.1%})"
            )
    if errs:
        print(f"largest departure of the law from the diagnosis: {max(map(abs, errs)):.2%}")


if __name__ == "__main__":
    main()
