"""The parametric bootstrap: what the whole pipeline does on data that have no gap.

Every decision of the diagnoser that a constant once made is a test here, at a stated level,
calibrated on the data at hand. A *world* is a model taken as the truth (the nominal model, or
the nominal model with the effects selected so far) with its fitted values, plus noise drawn
from the fitted noise model of every (run, camera, axis) series (:mod:`.floor`: white and a
short-correlated part, the channels of a cycle correlated as the floor found them). In each
replicate the whole scoring is redone exactly as on the data: α (and the world's effect
amplitudes) refitted on the training runs, every candidate family profiled on its grid by the
training residual, held-out offsets refitted, the held-out mean square taken. The statistics:

``hold_ms``
    the world's own held-out mean square after refitting (is the residual at the floor?);
``low``
    the mean square of the held-out residual smoothed over three allowed pose-noise correlation
    times (is the residual white at the thermal time scales?);
``gain``
    per family, the drop in held-out mean square when it is added; the null of the largest
    over every family is what one candidate's gain must beat (the search over the library is
    in the null, so no multiplicity correction is left to make).

Column 0 of every statistic is the data itself; columns 1… are the replicates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.linalg import solve_triangular

from thermrs.diagnose.family_fit import DesignMatrix
from thermrs.diagnose.floor import NoiseFloor
from thermrs.stats import unit_qr

__all__ = [
    "Batch",
    "BatchFit",
    "Nested",
    "Observations",
    "draw_noise",
    "format_p",
    "quantile_above",
]

FloatArray = npt.NDArray[np.float64]


@dataclass
class Observations:
    """Observation vectors with their training (weighted) and held-out rows split out, and
    the models already factored on them (:meth:`Batch.nested`)."""

    y: FloatArray
    yw: FloatArray
    yy: FloatArray
    y_ho: FloatArray
    nested: dict[tuple[int, ...], tuple[object, Nested | None]] = field(default_factory=dict)


@dataclass
class Nested:
    """A model fitted to many observation vectors, factored so that columns can be added to
    it (:meth:`Batch.fit_added`): the QR of its training columns (unit-norm, offsets
    included), their projections of the observations, and its centred held-out residual."""

    q: FloatArray  # n_tr × p, orthonormal
    r: FloatArray  # p × p, of the unit-norm columns
    norms: FloatArray  # p
    coef: FloatArray  # p × B: α, the model's columns, then the training mountings
    rss: FloatArray  # (B,)
    x_ho: FloatArray  # n_ho × k: the model's own columns (α first) on the held-out rows
    resid_ho: FloatArray  # n_ho × B, its held-out mounting means removed


@dataclass
class BatchFit:
    """One model fitted to many observation vectors at once."""

    train_rss: FloatArray  # (B,)
    hold_ms: FloatArray  # (B,)
    hold_resid: FloatArray | None  # (n_hold, B)
    fitted: FloatArray | None  # (2n, B) fitted values (model + offsets), when asked
    #: (k, B): α, then the amplitude of each of the model's columns, when asked.
    coef: FloatArray | None = None


class Batch:
    """Least squares of the design's training rows for many observation vectors.

    Parameters
    ----------
    design
        The diagnoser's design (:class:`thermrs.diagnose.family_fit.DesignMatrix`).
    window_s
        The smoothing window of the low-frequency statistic (seconds).
    """

    def __init__(self, design: DesignMatrix, window_s: float):
        self.d = design
        self.tr = np.flatnonzero(design.train)
        self.ho = np.flatnonzero(design.hold)
        self.used = np.unique(design.group[self.tr])
        self.sw = np.sqrt(design.weights)
        off = design.offsets
        self.off_tr = off[np.ix_(self.tr, self.used)]
        hold_groups = np.unique(design.group[self.ho])
        self.off_ho = off[np.ix_(self.ho, hold_groups)]
        w_ho = design.weights[self.ho]
        self.w_ho = w_ho
        self.wsum_ho = self.off_ho.T @ w_ho
        # Smoothing of each held-out series (sorted by time) for the low-frequency statistic.
        self.smooth: list[tuple[npt.NDArray[np.intp], int]] = []
        t = design.order[self.ho]
        for g in hold_groups:
            rows = np.flatnonzero(design.group[self.ho] == g)
            rows = rows[np.argsort(t[rows], kind="stable")]
            if len(rows) < 4:
                continue
            dt = float(np.median(np.diff(t[rows])))
            m = int(np.clip(round(window_s / dt) if dt > 0 else 1, 2, max(2, len(rows) // 3)))
            self.smooth.append((rows, m))

    def prepare(self, y: FloatArray) -> Observations:
        """Observation vectors (2n × B) split once for many fits."""
        yw = y[self.tr] * self.sw[self.tr, None]
        return Observations(y=y, yw=yw, yy=np.sum(yw * yw, axis=0), y_ho=y[self.ho])

    def fit(
        self,
        columns: FloatArray | None,
        y: FloatArray | Observations,
        *,
        keep: bool = False,
    ) -> BatchFit | None:
        """Fit α, the columns' amplitudes and the training offsets to every column of ``y``
        (2n × B, or prepared by :meth:`prepare`); None when the design is rank-deficient."""
        obs = y if isinstance(y, Observations) else self.prepare(y)
        nest = self._nested(columns, obs)
        if nest is None:
            return None
        fitted = coef = None
        if keep:
            k = nest.x_ho.shape[1]
            coef = nest.coef[:k]
            fitted = self._x_all(columns) @ coef
            fitted[self.tr] += self.off_tr @ nest.coef[k:]
            fitted[self.ho] = obs.y_ho - nest.resid_ho  # the model and the held-out mountings
        return BatchFit(
            train_rss=np.maximum(nest.rss, 0.0),
            hold_ms=np.mean(nest.resid_ho**2, axis=0),
            hold_resid=nest.resid_ho,
            fitted=fitted,
            coef=coef,
        )

    def _x_all(self, columns: FloatArray | None) -> FloatArray:
        """The α column and ``columns`` (every row)."""
        d = self.d
        return d.s[:, None] if columns is None else np.column_stack([d.s[:, None], columns])

    def _centre(self, resid_ho: FloatArray) -> FloatArray:
        """Held-out residuals with each held-out mounting's weighted mean removed."""
        means = (self.off_ho.T @ (self.w_ho[:, None] * resid_ho)) / self.wsum_ho[:, None]
        out: FloatArray = resid_ho - self.off_ho @ means
        return out

    def nested(
        self, model: Sequence[object], columns: FloatArray | None, obs: Observations
    ) -> Nested | None:
        """The model (its ``columns``, stacked from the objects ``model``) factored on
        ``obs`` for :meth:`fit_added`, computed once per model and observations; None when
        the design is rank-deficient."""
        key = tuple(id(m) for m in model)
        hit = obs.nested.get(key)
        if hit is not None:
            return hit[1]
        out = self._nested(columns, obs)
        obs.nested[key] = (list(model), out)  # the objects kept: their ids stay theirs
        return out

    def _nested(self, columns: FloatArray | None, obs: Observations) -> Nested | None:
        x_all = self._x_all(columns)
        k = x_all.shape[1]
        x = np.column_stack([x_all[self.tr], self.off_tr]) * self.sw[self.tr, None]
        qr = unit_qr(x, rtol=1e-10)
        if qr is None:
            return None
        q, r, norms = qr
        qty = q.T @ obs.yw
        coef = solve_triangular(r, qty) / norms[:, None]
        rss = obs.yy - np.sum(qty * qty, axis=0)
        x_ho = x_all[self.ho]
        resid_ho = self._centre(obs.y_ho - x_ho @ coef[:k])
        return Nested(q=q, r=r, norms=norms, coef=coef, rss=rss, x_ho=x_ho, resid_ho=resid_ho)

    def fit_added(self, nested: Nested, columns: FloatArray, obs: Observations) -> BatchFit | None:
        """:meth:`fit` of the nested model with ``columns`` added, from its factorisation:
        the columns orthogonalised against it (Gram–Schmidt, twice), so that only they meet
        the observations. The same least squares as :meth:`fit`; None when rank-deficient."""
        c = np.asarray(columns, dtype=np.float64)
        if c.ndim == 1:
            c = c[:, None]
        cw = c[self.tr] * self.sw[self.tr, None]
        cn = np.linalg.norm(cw, axis=0)
        if np.any(cn == 0) or not np.all(np.isfinite(cn)):
            return None
        cw = cw / cn
        p = nested.q.T @ cw
        cp = cw - nested.q @ p
        p2 = nested.q.T @ cp
        cp -= nested.q @ p2
        p += p2
        q1, r1 = np.linalg.qr(cp)
        if np.abs(np.diag(r1)).min() < 1e-10 * max(float(np.abs(np.diag(nested.r)).max()), 1.0):
            return None
        t = q1.T @ obs.yw
        g = solve_triangular(r1, t)  # the added columns' coefficients (unit-norm columns)
        m = solve_triangular(nested.r, p)  # how the model's coefficients move per unit of g
        k = nested.x_ho.shape[1]
        e = c[self.ho] / cn - nested.x_ho @ (m[:k] / nested.norms[:k, None])
        resid_ho = nested.resid_ho - self._centre(e) @ g
        return BatchFit(
            train_rss=np.maximum(nested.rss - np.sum(t * t, axis=0), 0.0),
            hold_ms=np.mean(resid_ho**2, axis=0),
            hold_resid=resid_ho,
            fitted=None,
        )

    def low(self, hold_resid: FloatArray) -> FloatArray:
        """The low-frequency statistic of held-out residuals (n_hold × B) (module docs)."""
        tot = np.zeros(hold_resid.shape[1])
        cnt = 0
        for rows, m in self.smooth:
            r = hold_resid[rows]
            c = np.cumsum(np.vstack([np.zeros((1, r.shape[1])), r]), axis=0)
            ma = (c[m:] - c[:-m]) / m
            tot += np.sum(ma**2, axis=0)
            cnt += ma.shape[0]
        return tot / max(cnt, 1)


def draw_noise(
    design: DesignMatrix, floor: NoiseFloor, draws: int, rng: np.random.Generator
) -> FloatArray:
    """Noise vectors (2n × draws) from the fitted noise model of every series (module docs).

    Every channel of a run (camera × chip axis) gets its own white and correlated parts
    (:class:`.floor.SeriesNoise`); the channels of one cycle are drawn correlated as the
    floor found them (:class:`.floor.ChannelCorrelation`: the white draws as the white parts
    are, the correlated part's innovations as the correlated parts are), or, where it has
    no estimate for a run, both as the measured spots' increments from cycle to cycle are.
    """
    vs = design.vs
    n = vs.n
    out = np.zeros((2 * n, draws))
    noise = floor.by_key()
    fallback = floor.holdout_um if np.isfinite(floor.holdout_um) else floor.train_um
    for run, chans, pos, chol in _plan(design):
        m = max(int(p.max()) for p in pos) + 1
        k = len(chans)
        chol_w: FloatArray = chol
        chol_a: FloatArray = chol
        cc = floor.correlations.get(run)
        if cc is not None:
            keys = tuple((str(vs.camera[rows[0] % n]), axis) for rows, axis in chans)
            if set(keys) == set(cc.channels) and len(keys) == len(cc.channels):
                at = [cc.channels.index(key) for key in keys]
                chol_w = np.asarray(np.linalg.cholesky(cc.white[np.ix_(at, at)]), np.float64)
                chol_a = np.asarray(np.linalg.cholesky(cc.correlated[np.ix_(at, at)]), np.float64)
        # Channel by channel, cycles × draws: one product with the correlation's factor.
        zw = (chol_w @ rng.standard_normal((k, m * draws))).reshape(k, m, draws)
        za = (chol_a @ rng.standard_normal((k, m * draws))).reshape(k, m, draws)
        for c, (rows, axis) in enumerate(chans):
            cam = str(vs.camera[rows[0] % n])
            s = noise.get((run, cam, axis))
            w = s.white_um if s is not None else fallback
            out[rows] = w * zw[c, pos[c]] + _ar(vs.t_s[rows % n], za[c, pos[c]], s)
    return out


def _plan(
    design: DesignMatrix,
) -> list[
    tuple[str, list[tuple[npt.NDArray[np.intp], str]], list[npt.NDArray[np.intp]], FloatArray]
]:
    """Per run: its channels (rows, axis), each row's cycle position, and the Cholesky factor
    of the channels' correlation (from first differences of the measured spots across
    cycles); computed once per design."""
    cached = getattr(design, "_noise_plan", None)
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    from thermrs.diagnose.resample import cycle_units

    vs = design.vs
    n = vs.n
    units = cycle_units(vs)
    plan = []
    for run in dict.fromkeys(vs.run.tolist()):
        chans: list[tuple[npt.NDArray[np.intp], str]] = []
        for g in vs.groups:
            if vs.run[g[0]] == run:
                chans += [(g, "u"), (g + n, "v")]
        cyc = np.unique(units[vs.run == run])
        pos = [np.searchsorted(cyc, units[rows % n]) for rows, _ in chans]
        mat = np.full((len(cyc), len(chans)), np.nan)
        for c, (rows, _) in enumerate(chans):
            mat[pos[c], c] = design.y[rows]
        d = np.diff(mat, axis=0)
        k = len(chans)
        r = np.eye(k)
        for i in range(k):
            for j in range(i + 1, k):
                ok = np.isfinite(d[:, i]) & np.isfinite(d[:, j])
                if ok.sum() > 5 and np.std(d[ok, i]) > 0 and np.std(d[ok, j]) > 0:
                    r[i, j] = r[j, i] = float(np.corrcoef(d[ok, i], d[ok, j])[0, 1])
        w, v = np.linalg.eigh(r)
        r = (v * np.maximum(w, 1e-6)) @ v.T
        dg = np.sqrt(np.diag(r))
        r = r / np.outer(dg, dg)
        plan.append((str(run), chans, pos, np.linalg.cholesky(r)))
    design._noise_plan = plan  # type: ignore[attr-defined]
    return plan


def _ar(t: FloatArray, z: FloatArray, s: object) -> FloatArray:
    """A stationary AR(1) in time (irregular spacing) with the series' correlated part."""
    from thermrs.diagnose.floor import SeriesNoise

    if not isinstance(s, SeriesNoise) or s.correlated_um <= 0 or s.tau_c_s <= 0:
        return np.zeros_like(z)
    phi = np.exp(-np.maximum(np.diff(t), 0.0) / s.tau_c_s)
    out = z * s.correlated_um
    out[1:] *= np.sqrt(1.0 - phi * phi)[:, None]
    for i in range(1, len(t)):  # out[i] = φ_i·out[i−1] + √(1−φ_i²)·z_i, in place
        out[i] += phi[i - 1] * out[i - 1]
    return out


def quantile_above(null: FloatArray, observed: float) -> float:
    """The bootstrap p-value of ``observed`` against ``null``: P(null ≥ observed), with the
    observed value counted among the draws, (1 + k)/(B + 1). It is never below 1/(B + 1):
    beyond every draw the data only say "less than that" (:func:`format_p`)."""
    null = null[np.isfinite(null)]
    k = int(np.sum(null >= observed))
    return float((1 + k) / (len(null) + 1))


def format_p(p: float, draws: int) -> str:
    """A bootstrap p-value with its relation, for "p {…}": ``= 0.12``, or ``< 0.005`` where
    it is the smallest the draws resolve."""
    floor = 1.0 / (draws + 1)
    if draws > 0 and p <= floor * (1 + 1e-9):
        return f"< {floor:.2g}" if floor < 0.01 else f"≤ {floor:.2g}"
    return f"= {p:.3f}" if p < 0.01 else f"= {p:.2f}"
