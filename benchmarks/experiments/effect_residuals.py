"""Issue #4's effect table: per SPEC §6 effect, the residual RMS the nominal model leaves on a
simulated recording against the RMS the effect's parameters imply (the functions of
``tests/model/test_effect_residuals.py``).

Run:  python benchmarks/experiments/effect_residuals.py
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))


def main() -> None:
    import thermrs
    from thermrs.fit import fit_alpha

    from tests.support.effects import EFFECTS, implied, run

    rig = thermrs.load_rig()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        t0, _ = run(tmp, rig, "none")
        base = fit_alpha([t0], rig)
        print(f"none: rms {base.rms_um:.3f} µm, α {base.alpha_per_k * 1e6:.3f}e-6/K\n")
        print("| effect | implied rms (µm) | measured rms (µm) | excess over none (µm) "
              "| α implied | α measured |")  # fmt: skip
        print("| --- | ---: | ---: | ---: | ---: | ---: |")
        for name in sorted(EFFECTS):
            t, s = run(tmp, rig, name)
            m = fit_alpha([t], rig)
            w = fit_alpha([implied(t, s, rig, name)], rig)
            ex = math.sqrt(max(m.rms_um**2 - base.rms_um**2, 0.0))
            print(
                f"| {name} | {w.rms_um:.3f} | {m.rms_um:.3f} | {ex:.3f} "
                f"| {w.alpha_per_k * 1e6:.3f} | {m.alpha_per_k * 1e6:.3f} |"
            )


if __name__ == "__main__":
    main()
