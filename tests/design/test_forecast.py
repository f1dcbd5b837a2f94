"""The design's truth route against the recorded route: the same scenario and seed simulated
without images (:func:`thermrs.design.forecast.truth_runs`) and recorded, then read back by the
extraction (:func:`thermrs.design.forecast.simulated_runs`). The extraction is the independent
reader here: the two routes share the truth, so every visit's spot must agree to within the
centroids' noise, and the noise floor the diagnoser measures to within a few per cent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import thermrs
from thermrs.design.forecast import simulated_runs, truth_runs
from thermrs.diagnose import noise_floor_um

SCENARIO = """format = "thermrs-scenario/1"
name = "truth against recording"

[[run]]
name = "t1"
speed_pct = 75
duration_min = 240
cycle_s = 300
start = "ambient"

[[run]]
name = "t2"
speed_pct = 10
duration_min = 240
cycle_s = 300
start = "continue"

[camera]
frames_per_visit = 1

[output]
compression = "none"
"""


@pytest.mark.filterwarnings("ignore:Sortedness of columns cannot be checked")
def test_the_truth_route_is_the_recording_without_its_centroid_noise(
    paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    text = Path(paper_rig.source).read_text()
    rec = simulated_runs(paper_rig, text, SCENARIO, workdir=tmp_path, stem="rec", seed=4)
    tru = truth_runs(paper_rig, text, SCENARIO, workdir=tmp_path, stem="tru", seed=4)
    assert [str(t["run"][0]) for t in rec] == [str(t["run"][0]) for t in tru] == ["t1", "t2"]
    for a, b in zip(rec, tru, strict=True):
        # A visit's time is its frame's stamp in the truth, the visit's in the run table.
        both = (
            a.sort("t_ns")
            .join_asof(
                b.sort("t_ns"),
                on="t_ns",
                by="camera",
                strategy="nearest",
                tolerance=60_000_000_000,
                suffix="_truth",
            )
            .drop_nulls("u_um_truth")
        )
        assert both.height >= b.height - 2  # a frame may lose its spot at the chip's edge
        for axis in ("u_um", "v_um"):
            d = (both[axis] - both[f"{axis}_truth"]).to_numpy()
            # The centroid's noise: a few hundredths of a pixel of 8.3–8.6 µm (0.24 µm rms
            # measured), nothing of the pose error, which both routes share.
            assert float(np.sqrt(np.mean(d**2))) < 0.5, axis
        for roi in ("link2", "link3"):
            d = (both[f"{roi}_c"] - both[f"{roi}_c_truth"]).to_numpy()
            assert float(np.sqrt(np.mean(d**2))) < 0.1, roi  # the IR camera's reading noise
    f_rec = noise_floor_um([rec[0]], [rec[1]], paper_rig)
    f_tru = noise_floor_um([tru[0]], [tru[1]], paper_rig)
    # Both routes share the pose errors; the centroids' noise adds (0.24/1.5)² / 2 ≈ 1 %.
    assert abs(f_rec / f_tru - 1.0) < 0.03
