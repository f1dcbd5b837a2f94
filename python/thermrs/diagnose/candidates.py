"""The candidates: each effect's best family, fitted on the training runs with its non-linear
parameters refined, and the evidence for it (the ranking of the JSON and the report).

Evidence per candidate (added to the nominal model):

- ``gain_p``: the held-out gain's p-value against the null world's largest gain over every
  family (:mod:`.selection`), the test that decides;
- ``gain_z``: the held-out gain over its standard error given the runs (the two fitted
  predictions fixed, the held-out noise drawn from the floor's model: :func:`.accuracy.gain_se`),
  descriptive;
- ``gap_closed``: the share of the gap above the held-out floor it closes (capped at 1; above 1
  the floor is off, said by ``gap_closed_raw``);
- ``delta_aicc``: ΔAICc on the training runs' effective sample size, penalty by the extra
  parameters over the nominal fit;
- ``placebo_holdout_rms_um``: the same family fitted to drivers shifted by half of each series;
- ``stability``: how often it is the best training fit among the leading five on block
  resamples of whole cycles;
- ``plausible``: its parameters inside the effect's physical bounds (the core's) and, where it
  has one, its amplitude relative to α positive (a structure cannot expand against its heat).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.accuracy import gain_se
from thermrs.diagnose.family_fit import DesignMatrix, Fit
from thermrs.diagnose.selection import Choice, FamilyGrid
from thermrs.effects import EFFECT_NAMES, Family, InstrumentEffect, is_instrument
from thermrs.effects import from_dict as effect_from_dict
from thermrs.errors import InputError
from thermrs.rig import Rig
from thermrs.signatures import VisitSet
from thermrs.stats import moving_block_indices

__all__ = ["Candidate", "is_plausible", "profile_interval", "score"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class Candidate:
    """One effect's leading family with its refined fit and evidence."""

    family: Family
    fit: Fit
    params: dict[str, Any]
    ci: dict[str, Any]
    gain: float
    gain_z: float
    gain_p: float | None
    closed: float | None
    closed_raw: float | None
    d_aicc: float
    plausible: bool
    identifiable: float
    significant: bool
    placebo_rms: float | None = None
    placebo_beaten: bool | None = None
    stability: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def effect(self) -> str:
        return self.family.effect


def _params(fam: Family, f: Fit, first: int) -> tuple[dict[str, Any], dict[str, Any]]:
    """The family's SPEC parameters from a fit whose family columns start at ``first``."""
    k = len(f.beta) - first
    idx = [0, *range(1 + first, 1 + first + k)]
    cov = f.cov[np.ix_(idx, idx)]
    return fam.params(f.eta, f.alpha, f.beta[first:], cov)


def profile_interval(
    design: DesignMatrix,
    fam: Family,
    f: Fit,
    n_eff: float,
    prefix: FloatArray | None = None,
) -> dict[str, list[float]]:
    """The refined parameter's profile-likelihood interval (:meth:`DesignMatrix.profile_ci`),
    as ``params_ci95`` holds it; empty for a family without one."""
    if not fam.refine or fam.refine[0] not in f.eta:
        return {}
    got = design.profile_ci(fam, f.eta, n_eff, prefix=prefix)
    return {} if got is None else {fam.refine[0]: [got[0], got[1]]}


def is_plausible(
    rig: Rig,
    fam: Family,
    params: dict[str, Any],
    ci: dict[str, Any],
    min_delay_s: float = 0.0,
    reading_noise_k: float | None = None,
) -> bool:
    """The candidate's parameters are physically possible (module docs); a thermal camera's
    clock offset shorter than ``min_delay_s`` (the longest correlation the floor counts as
    noise, below which a lag is not told from noise either) is not told from the structure's
    own short lags; readings smoothed more (``ir_noise``) only where they scatter
    (``reading_noise_k``, the largest ROI's, measured from the readings) by more than the rig
    states (``tolerances.ir_noise_k``): a de-noising the null world, whose readings carry
    no noise of their own, cannot weigh, is offered only for readings noisier than stated."""
    if fam.effect == "ir_clock" and abs(float(params.get("s", 0.0))) < min_delay_s:
        return False
    if fam.effect == "ir_noise" and (
        reading_noise_k is None or reading_noise_k <= float(rig.tolerances.get("ir_noise_k", 0.0))
    ):
        return False
    w = ci.get("weight")
    if w is not None and float(np.mean(w)) <= 0:
        return False
    try:
        if fam.effect in EFFECT_NAMES:
            effect_from_dict({"name": fam.effect, **params}, rig=rig)
        elif is_instrument(fam.effect):
            # Within its bound, and beyond what the rig states of the instrument: a reading
            # within twice its stated calibration is not a miscalibrated instrument.
            e = effect_from_dict({"name": fam.effect, **params}, rig=rig)
            return isinstance(e, InstrumentEffect) and e.beyond_statement(rig)
    except (InputError, TypeError, ValueError):
        return False
    return True


def plausibility(design: DesignMatrix, rig: Rig) -> Any:
    """A cached test of a choice added to a model (for :func:`.selection.forward_selection`)."""
    cache: dict[tuple[str, ...], bool] = {}

    def ok(model: list[Choice], ch: Choice) -> bool:
        key = (*[c.label for c in model], ch.label, repr(ch.eta))
        if key in cache:
            return cache[key]
        cols = np.column_stack([*[c.columns for c in model], ch.columns])
        first = sum(c.columns.shape[1] for c in model)
        try:
            f = design.fit(cols, ch.eta, label=ch.label, covariance="iid")
            params, ci = _params(ch.grid.family, f, first)
            good = is_plausible(
                rig, ch.grid.family, params, ci, design.min_tau_min * 60.0, design.reading_noise_k
            )
        except (ValueError, np.linalg.LinAlgError, InputError):
            good = False
        cache[key] = good
        return good

    return ok


def score(
    design: DesignMatrix,
    base: Fit,
    grids: list[FamilyGrid],
    step_gain_p: dict[str, float],
    significant: set[str],
    *,
    rig: Rig,
    floor_um: float,
    n_eff_train: float,
    units: npt.NDArray[np.intp],
    placebo: VisitSet,
    bootstrap: int,
    rng: np.random.Generator,
    noise: FloatArray,
) -> list[Candidate]:
    """Every effect's leading family (least held-out residual), refined and with evidence,
    sorted by held-out rms; ``noise``: draws of the held-out rows' noise (rows × draws, from
    the floor's model) for the gains' standard errors."""
    hold = np.flatnonzero(design.hold)
    fits: list[tuple[Family, Fit]] = []
    for fg in grids:
        f = design.profile(fg.family)
        if f is not None:
            fits.append((fg.family, f))
    fits.sort(key=lambda t: t[1].holdout_rms_um)
    lead: dict[str, tuple[Family, Fit]] = {}
    for fam, f in fits:
        lead.setdefault(fam.effect, (fam, f))
    out: list[Candidate] = []
    base_rms = base.holdout_rms_um
    gap = base_rms - floor_um
    for fam, f in lead.values():
        d = base.residual[hold] ** 2 - f.residual[hold] ** 2
        se = gain_se(f.residual[hold], base.residual[hold], noise)
        params, ci = fam.params(f.eta, f.alpha, f.beta, f.cov)
        ci = {**ci, **profile_interval(design, fam, f, n_eff_train)}
        k = f.n_params - base.n_params
        n = max(n_eff_train, k + 3.0)
        n_rows = float(design.train.sum())

        def aicc(rss: float, p: int, n: float = n, n_rows: float = n_rows) -> float:
            pen = 2 * p + 2 * p * (p + 1) / max(n - p - 1, 1.0)
            return float(n * np.log(rss / n_rows) + pen)

        raw = (base_rms - f.holdout_rms_um) / gap if gap > 0 else None
        out.append(
            Candidate(
                family=fam,
                fit=f,
                params=params,
                ci=ci,
                gain=float(d.mean()),
                gain_z=float(d.mean() / se) if se > 0 else 0.0,
                gain_p=step_gain_p.get(fam.label),
                closed=None if raw is None else min(raw, 1.0),
                closed_raw=raw,
                d_aicc=aicc(f.train_rss_w, base.n_params + k)
                - aicc(base.train_rss_w, base.n_params),
                plausible=is_plausible(
                    rig, fam, params, ci, design.min_tau_min * 60.0, design.reading_noise_k
                ),
                identifiable=design.identifiable(f.columns) if f.columns is not None else 0.0,
                significant=fam.label in significant,
            )
        )
    out.sort(key=lambda c: c.fit.holdout_rms_um)
    _placebos(design, base, out, placebo)
    _stability(design, out[:5], units, bootstrap, rng)
    return out


def _placebos(design: DesignMatrix, base: Fit, cands: list[Candidate], placebo: VisitSet) -> None:
    hold = design.hold
    for c in cands:
        try:
            pc = c.family.columns(placebo, c.fit.eta)
            pf = design.fit(pc, c.fit.eta, label="placebo", covariance="iid")
            c.placebo_rms = pf.holdout_rms_um
            pg = float(np.mean(base.residual[hold] ** 2 - pf.residual[hold] ** 2))
            c.placebo_beaten = bool(pg <= 0.5 * c.gain)
        except (ValueError, np.linalg.LinAlgError, InputError):
            c.placebo_rms = None
            c.placebo_beaten = None


def _stability(
    design: DesignMatrix,
    lead: list[Candidate],
    units: npt.NDArray[np.intp],
    bootstrap: int,
    rng: np.random.Generator,
) -> None:
    """Share of block resamples of whole training cycles on which each leads (module docs)."""
    if not lead or bootstrap <= 0:
        return
    vs = design.vs
    train_v = np.flatnonzero(design.train[: vs.n])
    cyc = units[train_v]
    uniq = np.unique(cyc)
    run_of = np.array([vs.run[train_v[np.argmax(cyc == u)]] for u in uniq])
    gen = moving_block_indices(run_of, block_length=3, rng=rng, order=uniq.astype(np.float64))
    members = {u: train_v[cyc == u] for u in uniq}
    wins = np.zeros(len(lead))
    for _ in range(bootstrap):
        pick = next(gen)
        vis = np.concatenate([members[uniq[i]] for i in pick])
        rows = np.concatenate([vis, vis + vs.n])
        rss = []
        for c in lead:
            try:
                bf = design.fit(c.fit.columns, c.fit.eta, label="b", rows=rows, covariance="iid")
                rss.append(bf.train_rss_w)
            except (ValueError, np.linalg.LinAlgError):
                rss.append(np.inf)
        wins[int(np.argmin(rss))] += 1
    for i, c in enumerate(lead):
        c.stability = float(wins[i] / bootstrap)
