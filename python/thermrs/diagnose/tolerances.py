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
tolerances, which is the world the user lives in. In the world of a model with effects (a
rival's, an alternative choice's, a later step's), the IR camera's signatures are that model's
(:class:`ModelNuisance`): a joint offset driven by link 3 moves with link 3's reading error as
the expansion does. Without that, on the independent bench world's runs, a joint offset's
true temperature was rejected at p 0.001 against another link's (IR drift and gain within
their tolerances); with it, at 0.006.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.effects import Family
from thermrs.rig import Rig, geometry_variants
from thermrs.signatures import VisitSet

__all__ = ["ModelNuisance", "Term", "nuisance_signatures"]

FloatArray = npt.NDArray[np.float64]
#: One effect of a fitted model: its family, its parameters, its columns there (2n × m).
Term = tuple[Family, dict[str, float], FloatArray]


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


def _rise(vs: VisitSet, rig: Rig, r: str) -> FloatArray:
    room = vs.temps.get("ambient")
    room = room if room is not None else np.full(vs.n, rig.reference_c)
    return np.concatenate([vs.temps[r] - room] * 2)


def _sensitivity(vs: VisitSet, alpha: float, rois: list[str]) -> dict[str, FloatArray]:
    """The nominal model's spots' change (2n, µm) per kelvin of each ROI's reading."""
    hot = vs.positions(alpha_per_k=alpha)
    sens: dict[str, FloatArray] = {}
    for r in rois:
        temps = dict(vs.temps)
        temps[r] = temps[r] + 1.0
        sens[r] = vs.replaced(temps=temps).positions(alpha_per_k=alpha) - hot  # µm per K
    return sens


def _ir(vs: VisitSet, rig: Rig, sens: dict[str, FloatArray]) -> list[tuple[str, FloatArray]]:
    """The IR camera's tolerances' signatures, for a model whose spots move by ``sens``
    (2n, µm per K of each ROI's reading)."""
    tol = rig.tolerances
    rois = list(sens)
    if not rois:
        return []
    rise = {r: _rise(vs, rig, r) for r in rois}
    out: list[tuple[str, FloatArray]] = []
    if tol["ir_scale"] > 0:
        common = np.sum([sens[r] * rise[r] for r in rois], axis=0)
        out.append(("IR gain (common)", tol["ir_scale"] * common))
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


class ModelNuisance:
    """The tolerances' signatures about a fitted model with effects, not the nominal one.

    An IR reading's error moves every term of the model that reads that temperature: a joint
    offset or an unmodelled length driven by link 3 moves with link 3's IR drift, gain and
    clock as the nominal expansion does. A null world in which such a model is the truth
    (a rival's, an alternative choice's, a later step's) draws the IR tolerances through the
    model's own sensitivity to each reading: α's part (the nominal one, at the model's α)
    plus each effect's column's change per kelvin of the reading, times its fitted
    amplitude. The geometry's signatures are the nominal ones at the model's α (an effect's
    own interaction with a length's tolerance is second order).

    Parameters
    ----------
    vs
        The visits the families' columns were computed on.
    rig
        The rig (its tolerances).
    alpha
        The nominal fit's α (the geometry's signatures were computed at it).
    geometry
        The geometry's signatures (2n × g) at ``alpha``.
    """

    def __init__(self, vs: VisitSet, rig: Rig, alpha: float, geometry: FloatArray):
        self.vs = vs
        self.rig = rig
        self.alpha = alpha
        self.geometry = geometry
        self.rois = [t for t in vs.temps if t != "ambient"]
        mapped = [r for r in self.rois if r in rig.mapped_temperatures]
        nominal = _sensitivity(vs, alpha, mapped) if alpha != 0 else {}
        zero = np.zeros(2 * vs.n)
        #: Per ROI: the nominal spots' change per K of its reading, per unit α.
        self.per_alpha = {r: (nominal[r] / alpha if r in nominal else zero) for r in self.rois}
        self._derivatives: dict[tuple[str, tuple[tuple[str, float], ...]], Any] = {}

    def _derivative(
        self, family: Family, eta: dict[str, float], cols: FloatArray
    ) -> dict[str, FloatArray]:
        """Per ROI: the family's columns' change (2n × m) per kelvin of its reading."""
        key = (family.label, tuple(sorted(eta.items())))
        hit: dict[str, FloatArray] | None = self._derivatives.get(key)
        if hit is not None:
            return hit
        out = {}
        base = cols.reshape(2 * self.vs.n, -1)
        for r in self.rois:
            temps = dict(self.vs.temps)
            temps[r] = temps[r] + 1.0
            try:
                moved = np.asarray(family.columns(self.vs.replaced(temps=temps), eta))
                d = moved.reshape(base.shape) - base
            except Exception:  # a family that cannot follow the reading: no interaction
                d = np.zeros_like(base)
            out[r] = np.where(np.isfinite(d), d, 0.0)
        self._derivatives[key] = out
        return out

    def ir_columns(
        self,
        terms: Sequence[tuple[Family, dict[str, float], FloatArray]],
        coef: FloatArray,
    ) -> list[tuple[str, FloatArray]]:
        """The IR camera's tolerances' signatures (name, 2n) about the model whose ``terms``
        (the family, its parameters, its columns there) were fitted with ``coef`` (α, then
        each column's amplitude)."""
        sens = {r: float(coef[0]) * self.per_alpha[r] for r in self.rois}
        j = 1
        for family, eta, cols in terms:
            d = self._derivative(family, eta, cols)
            m = cols.reshape(2 * self.vs.n, -1).shape[1]
            for r in self.rois:
                sens[r] = sens[r] + d[r] @ coef[j : j + m]
            j += m
        return _ir(self.vs, self.rig, sens)

    def moved(
        self,
        terms: Sequence[tuple[Family, dict[str, float], FloatArray]],
        coef: FloatArray,
        dtemps: dict[str, FloatArray],
    ) -> FloatArray:
        """How far (2n, µm) the spots of the model whose ``terms`` were fitted with ``coef``
        (α, then each column's amplitude) move when the ROIs' readings change by ``dtemps``
        (per ROI, n, K: a different change at every visit): α's expansion, linear in each
        reading, and each effect's columns computed again from the changed readings (a lag
        filters the change as it filters the readings)."""
        n = self.vs.n
        out = np.zeros(2 * n)
        temps = dict(self.vs.temps)
        for r, d in dtemps.items():
            if r in self.per_alpha:
                out += float(coef[0]) * self.per_alpha[r] * np.concatenate([d, d])
            temps[r] = temps[r] + d
        moved_vs = self.vs.replaced(temps=temps)
        j = 1
        for family, eta, cols in terms:
            base = cols.reshape(2 * n, -1)
            m = base.shape[1]
            try:
                new = np.asarray(family.columns(moved_vs, eta)).reshape(base.shape)
                out += np.where(np.isfinite(new - base), new - base, 0.0) @ coef[j : j + m]
            except Exception:  # a family that cannot follow the readings: no part of it
                pass
            j += m
        return out

    def of(
        self,
        terms: Sequence[tuple[Family, dict[str, float], FloatArray]],
        coef: FloatArray,
    ) -> FloatArray:
        """Every signature (2n × p) about that model: the geometry's at its α, then
        :meth:`ir_columns`."""
        scale = float(coef[0]) / self.alpha if self.alpha else 1.0
        ir = [c for _, c in self.ir_columns(terms, coef)]
        return np.column_stack([self.geometry * scale, *ir])


def nuisance_signatures(
    vs: VisitSet, rig: Rig, alpha: float, *, floor_um: float
) -> tuple[FloatArray, list[str], ModelNuisance]:
    """Every tolerance's signature (2n × p) about the nominal model at the fitted α, their
    names (module docs), and the same about any model with effects (:class:`ModelNuisance`).

    Signatures smaller than a thousandth of the noise floor everywhere are left out of the
    nominal ones (they cannot move a statistic).
    """
    rois = [t for t in rig.mapped_temperatures if t != "ambient" and vs.has(t)]
    geometry = _geometry(vs, rig, alpha)
    cols = [*geometry, *_ir(vs, rig, _sensitivity(vs, alpha, rois))]
    per_model = ModelNuisance(
        vs,
        rig,
        alpha,
        np.column_stack([c for _, c in geometry]) if geometry else np.zeros((2 * vs.n, 0)),
    )
    keep = [(n, c) for n, c in cols if float(np.max(np.abs(c))) > 1e-3 * max(floor_um, 1e-9)]
    if not keep:
        return np.zeros((2 * vs.n, 0)), [], per_model
    return np.column_stack([c for _, c in keep]), [n for n, _ in keep], per_model
