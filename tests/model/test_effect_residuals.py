"""Issue #4's round trip: the nominal model fitted to a simulated recording leaves residuals at
the noise level with no effect, and each SPEC §6 effect alone leaves the residual its
parameters imply.

"Implied" is computed here, independently of the simulator's output: the spot each visit should
show, from the effect's parameters through :class:`thermrs.ForwardModel` (or the closed forms of
the chip effects) at the true structure temperatures, is fitted with the nominal model on the
true surface temperatures, exactly as the recording is; its residual RMS is what the effect
implies. The recording's residual adds the measurement noise in quadrature.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.fit import fit_alpha
from thermrs.predict import noise_um

from tests.support.effects import EFFECTS, implied, run

#: Simulations and campaigns of minutes: skipped by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def baseline(tmp_path_factory: pytest.TempPathFactory) -> dict[str, float]:
    rig = thermrs.load_rig()
    table, samples = run(tmp_path_factory.mktemp("none"), rig, "none")
    f = fit_alpha([table], rig)
    noise = math.sqrt(
        np.mean(
            [
                noise_um(table.filter(pl.col("camera") == c)[f"{a}_um"].to_numpy()) ** 2
                for c in ("A", "B")
                for a in ("u", "v")
            ]
        )
    )
    ideal = fit_alpha([implied(table, samples, rig, "none")], rig)
    return {"rms": f.rms_um, "noise": noise, "alpha": f.alpha_per_k, "ideal": ideal.rms_um}


def test_no_effect_leaves_residuals_at_the_noise_level(baseline: dict[str, float]) -> None:
    """The nominal model on a `none` recording: residual RMS within 2× the measurement's own
    visit-to-visit noise, α within 1 % of the simulator's, and the noise-free version exact.

    (Issue #9: the noise is 0.11–0.15 µm per axis, as the within-visit centroid scatter
    says independently (0.10–0.12 µm); the von Neumann estimator used before read 0.29–0.35
    µm because the drift's own step from visit to visit was in it. The residual, 0.20 µm,
    also carries the ROI readings' error.)"""
    assert baseline["ideal"] < 1e-6
    assert baseline["rms"] < 2.0 * baseline["noise"], baseline
    assert baseline["noise"] < 0.5, baseline
    assert baseline["alpha"] == pytest.approx(23.2e-6, rel=0.01)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_each_effect_leaves_the_residual_its_parameters_imply(
    name: str, baseline: dict[str, float], tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    table, samples = run(tmp_path, paper_rig, name)
    measured = fit_alpha([table], paper_rig)
    want = fit_alpha([implied(table, samples, paper_rig, name)], paper_rig)
    if name == "laser_tilt":
        # A tilted laser mostly shifts the spot by a constant, which the per-camera offsets
        # absorb; what the expansion adds is nanometres (1° at 106 mm: 0.01 µm RMS). Implied
        # tiny, measured at the noise floor.
        assert want.rms_um < 0.05, want
        assert measured.rms_um < 1.1 * baseline["rms"] + want.rms_um
        return
    # Big enough to see: well above the noise floor.
    assert want.rms_um > 3 * baseline["rms"], (name, want.rms_um, baseline)
    excess = math.sqrt(max(measured.rms_um**2 - baseline["rms"] ** 2, 0.0))
    assert excess == pytest.approx(want.rms_um, rel=0.15), (name, excess, want.rms_um)
    # And the α the nominal model absorbs is the one the effect implies.
    assert measured.alpha_per_k == pytest.approx(want.alpha_per_k, rel=0.03, abs=0.3e-6), name
