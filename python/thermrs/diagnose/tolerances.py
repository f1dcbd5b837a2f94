"""The rig's tolerances in the null world: what a rig within its stated uncertainties leaves
over the nominal model, so that it is never named as an effect.

A real rig is never exactly its file: its lengths and chips are measured to tenths of a
millimetre, its IR camera is calibrated to a few per cent, its clocks disagree by seconds.
The rig file's ``[tolerances]`` (SPEC §3) states these as standard uncertainties. Each is a
direction in which the true rig may differ from the file; its *signature* is the change of
the fitted nominal model's spots (2n, u then v) when that quantity moves by one standard
uncertainty, computed with the same forward model the fits use:

geometry
    every DH length, twist and joint zero, each chip's centre and orientation, the laser's
    origin and direction — the change of the thermal part of the spots (α̂ times the change
    of :meth:`thermrs.signatures.VisitSet.alpha_column`); the static part is a constant per
    (run, camera), which the unknown mountings absorb;
IR camera
    a common gain on every ROI's rise above the room, each ROI's own gain, each ROI's offset
    drifting over each run, the IR clock per run (the spots' sensitivity to each mapped
    temperature, times the reading error).

Every null replicate (:mod:`.selection`) adds these signatures with independent standard
normal weights: the statistics then have the distribution they have over rigs within their
tolerances, which is the world the user lives in.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from thermrs.rig import Rig, geometry_variants
from thermrs.signatures import VisitSet

__all__ = ["nuisance_signatures"]

FloatArray = npt.NDArray[np.float64]


def _geometry(vs: VisitSet, rig: Rig, alpha: float) -> list[tuple[str, FloatArray]]:
    s0 = vs.alpha_column()
    out = []
    for name, data in geometry_variants(rig):
        try:
            moved = Rig.from_dict(data, source_name=f"{rig.source} ({name})")
            s1 = vs.replaced(rig=moved).alpha_column()
        except Exception:  # a variant the forward model cannot follow (the ray leaves a chip)
            continue
        col = alpha * (s1 - s0)
        if np.all(np.isfinite(col)):
            out.append((name, col))
    return out


def _ir(vs: VisitSet, rig: Rig, alpha: float) -> list[tuple[str, FloatArray]]:
    tol = rig.tolerances
    rois = [t for t in rig.mapped_temperatures if t != "ambient" and vs.has(t)]
    if not rois:
        return []
    hot = vs.positions(alpha_per_k=alpha)
    room = vs.temps.get("ambient")
    room = room if room is not None else np.full(vs.n, rig.reference_c)
    sens: dict[str, FloatArray] = {}
    for r in rois:
        temps = dict(vs.temps)
        temps[r] = temps[r] + 1.0
        sens[r] = vs.replaced(temps=temps).positions(alpha_per_k=alpha) - hot  # µm per K
    rise = {r: np.concatenate([vs.temps[r] - room] * 2) for r in rois}
    out: list[tuple[str, FloatArray]] = []
    if tol["ir_scale"] > 0:
        out.append(("IR gain (common)", tol["ir_scale"] * sum(sens[r] * rise[r] for r in rois)))
    if tol["ir_gain"] > 0:
        out += [(f"IR gain ({r})", tol["ir_gain"] * sens[r] * rise[r]) for r in rois]
    runs = list(dict.fromkeys(vs.run.tolist()))
    run2 = np.concatenate([vs.run, vs.run])
    for run in runs:
        rows = run2 == run
        if tol["ir_drift_k"] > 0:
            t = np.concatenate([vs.t_since_start] * 2)
            span = float(np.max(t[rows])) or 1.0
            for r in rois:
                col = np.where(rows, tol["ir_drift_k"] * sens[r] * t / span, 0.0)
                out.append((f"IR offset drift ({r}, run {run})", col))
        if tol["ir_clock_s"] > 0:
            col = np.zeros(2 * vs.n)
            for g in vs.groups:
                if vs.run[g[0]] != run or len(g) < 2:
                    continue
                t = vs.t_s[g]
                for r in rois:
                    rate = np.gradient(vs.temps[r][g], t)  # K/s
                    for off in (0, vs.n):
                        col[g + off] += tol["ir_clock_s"] * sens[r][g + off] * rate
            out.append((f"IR clock (run {run})", col))
    return out


def nuisance_signatures(
    vs: VisitSet, rig: Rig, alpha: float, *, floor_um: float
) -> tuple[FloatArray, list[str]]:
    """Every tolerance's signature (2n × p) at the fitted α, and their names (module docs).

    Signatures smaller than a thousandth of the noise floor everywhere are left out (they
    cannot move a statistic).
    """
    cols = [*_geometry(vs, rig, alpha), *_ir(vs, rig, alpha)]
    keep = [(n, c) for n, c in cols if float(np.max(np.abs(c))) > 1e-3 * max(floor_um, 1e-9)]
    if not keep:
        return np.zeros((2 * vs.n, 0)), []
    return np.column_stack([c for _, c in keep]), [n for n, _ in keep]
