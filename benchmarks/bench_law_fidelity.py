"""Backs the BENCHMARKS.md row "a compensation law is the model the diagnosis fitted".

A diagnosis reports the held-out rms its model leaves (``how_far.holdout_rms_after_um``); the
law exported from it (:func:`thermrs.compensate.compensation_law`), applied to the same
held-out runs (:meth:`~thermrs.compensate.CompensationLaw.check`), must leave the same. Each
seed's case of each effect at SNR 2 in the independent bench world (white and AR(1)) is
diagnosed and the law checked. Printed beside it, the same law with the effect's fitted
``weight`` dropped (the law before the effect carried it): a thermal lag with all of the
expansion lagging (the world's lag has two time constants, of which a first-order lag fits
only a share), an unmodelled length with the model's α (the world's length has its own).

    python benchmarks/bench_law_fidelity.py --first-seed 6200 --seeds 4 \
        --effect thermal_lag unmodelled_length
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

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--first-seed", type=int, default=6200)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--effect", nargs="+", default=["thermal_lag"])
    args = ap.parse_args()
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    for effect in args.effect:
        errs: list[float] = []
        for world in ("white", "ar1"):
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                scene = draw_scene(wrig, Campaign(), world, seed, tolerances=rig.tolerances)
                truths, _, _ = case_truths(wrig, scene, (effect,), 2.0, seed)
                tables = render(scene, tuple(truths))
                doc = diagnose(tables[:1], tables[1:], rig, seed=seed, bootstrap=0).to_json()
                v = doc["verdict"]
                if v["effect"] != effect or v["status"] != "identified":
                    print(f"{effect} {world} {seed}: {v['status']} {v['effect']}: no law")
                    continue
                model = diagnosed_model(doc, rig)
                law = compensation_law(rig, model).check(tables[1:], rig)["all"]
                unit = tuple(dataclasses.replace(e, weight=1.0) for e in model.effects)
                whole = compensation_law(rig, dataclasses.replace(model, effects=unit))
                old = whole.check(tables[1:], rig)["all"]["compensated_rms_um"]
                after = doc["how_far"]["holdout_rms_after_um"]
                got = law["compensated_rms_um"]
                errs.append(got / after - 1.0)
                print(
                    f"{effect} {world} {seed}: {v['status']}, weight "
                    f"{v['params'].get('weight', 1.0):.3f}; the diagnosis {after:.3f} µm, the "
                    f"law {got:.3f} ({got / after - 1:+.1%}), weight 1 {old:.3f} "
                    f"({old / after - 1:+.1%})"
                )
        if errs:
            print(
                f"{effect}: {len(errs)} laws; largest departure of the law from the "
                f"diagnosis {max(map(abs, errs)):.2%}"
            )


if __name__ == "__main__":
    main()
