"""The diagnoser's fitting engine: the nominal model and each effect family fitted on the
training runs, scored on the held-out runs.

Model of every visit's measured spot (u and v rows, µm)::

    y = offset[run, camera, axis] + α·s + E(η)·β + noise

``s`` is the spot's displacement per unit α (nominal model, :meth:`VisitSet.alpha_column`),
``E(η)`` a family's signature columns (:class:`thermrs.effects.Family`) at its profiled
non-linear parameters η, β their amplitudes. α and β come from the training runs alone, by
weighted least squares on unit-norm columns (QR, :func:`thermrs.stats.lstsq_qr`), each camera
and chip axis weighted by the inverse of its residual variance under the nominal model (fixed
for every candidate so that they are compared on one scale). A held-out run's offsets are
unknown mountings, so they are the only thing fitted on it: its residual is the measurement
minus α·s + E·β, centred per (camera, axis).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from scipy.optimize import minimize_scalar

from thermrs.effects import Family
from thermrs.signatures import VisitSet
from thermrs.stats import LeastSquares, lstsq_qr

if TYPE_CHECKING:
    from thermrs.diagnose.tolerances import ModelNuisance

__all__ = ["DesignMatrix", "Fit"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass
class Fit:
    """One model fitted on the training rows and applied to the held-out rows."""

    label: str
    alpha: float
    beta: FloatArray
    cov: FloatArray
    eta: dict[str, float]
    residual: FloatArray  # 2n, every row (held-out rows centred per group)
    train_rss_w: float
    train_rms_um: float
    holdout_rms_um: float
    holdout_max_um: float
    n_params: int
    lsq: LeastSquares | None = None
    columns: FloatArray | None = None
    extra: dict[str, Any] = field(default_factory=dict)


class DesignMatrix:
    """The visits of training and held-out runs with everything the fits share.

    Parameters
    ----------
    visits
        Every run's visits (:class:`VisitSet`).
    train_runs
        Names of the training runs; the other runs are held out.
    """

    def __init__(self, visits: VisitSet, train_runs: set[str]):
        self.vs = visits
        n = visits.n
        self.n = n
        run2 = np.concatenate([visits.run, visits.run])
        self.train: BoolArray = np.isin(run2, sorted(train_runs))
        self.hold: BoolArray = ~self.train
        self.s = visits.alpha_column()
        self.y = visits.y
        self.offsets, self.offset_names = visits.offset_columns()
        self.group = np.argmax(self.offsets, axis=1)
        cam2 = np.concatenate([visits.camera, visits.camera])
        self.channel = np.char.add(np.char.add(cam2, "/"), visits.axis)
        self.series = np.char.add(np.char.add(run2, "/"), cam2)
        # HAC: clustered by run (cameras see the same model error at once), a cycle's visits
        # (both axes, every camera) one unit.
        from thermrs.diagnose.resample import cycle_units

        self.cluster = run2
        cyc = cycle_units(visits)
        self.unit = np.concatenate([cyc, cyc])
        self.order = np.concatenate([visits.t_s, visits.t_s])
        self.weights = np.ones(2 * n)
        #: Shortest time constant (min) a family may take: faster than the floor's allowed
        #: noise correlation time, an effect cannot be told from noise (set by the floor step).
        self.min_tau_min = 0.0
        #: The largest ROI's reading scatter from visit to visit (K), measured from the
        #: readings (:func:`.reading_noise.reading_noise_k`); None before it is.
        self.reading_noise_k: float | None = None
        #: Signatures (2n × p) of the rig's tolerances, drawn in every null replicate
        #: (:mod:`.tolerances`; set by the floor step), and their names.
        self.nuisance: FloatArray = np.zeros((2 * n, 0))
        self.nuisance_names: list[str] = []
        #: The same signatures about a model with effects (None: the nominal ones serve).
        self.model_nuisance: ModelNuisance | None = None
        base = self.fit(None, {}, label="nominal")
        # Weights: inverse residual variance per camera and axis, from the nominal training fit.
        for ch in np.unique(self.channel):
            m = self.channel == ch
            mt = m & self.train
            r = base.residual[mt]
            var = float(np.mean(r**2)) if mt.sum() > 5 else float(np.mean(base.residual**2))
            self.weights[m] = 1.0 / max(var, 1e-6)

    # --- fitting -------------------------------------------------------------------------------
    def fit(
        self,
        columns: FloatArray | None,
        eta: dict[str, float],
        *,
        label: str,
        rows: npt.NDArray[np.intp] | None = None,
        covariance: str = "hac",
    ) -> Fit:
        """Fit α (and the columns' amplitudes) on the training rows (or the given subset of
        them, a bootstrap resample), score on the held-out rows."""
        k = 0 if columns is None else columns.shape[1]
        tr = np.flatnonzero(self.train) if rows is None else rows
        used = np.unique(self.group[tr])
        xs = [self.s[:, None]]
        if columns is not None:
            xs.append(columns)
        x_all = np.column_stack(xs)
        x = np.column_stack([x_all[tr], self.offsets[np.ix_(tr, used)]])
        lsq = lstsq_qr(
            x,
            self.y[tr],
            weights=self.weights[tr],
            covariance="hac" if covariance == "hac" else "iid",
            series=self.cluster[tr] if covariance == "hac" else None,
            units=self.unit[tr] if covariance == "hac" else None,
            order=self.order[tr] if covariance == "hac" else None,
        )
        coef = lsq.coef[: 1 + k]
        model = x_all @ coef
        resid = self.y - model
        # Training rows: their own offsets; held-out rows: offsets fitted with α, β fixed.
        out = np.empty_like(resid)
        for g in np.unique(self.group):
            m = self.group == g
            w = self.weights[m]
            out[m] = resid[m] - np.sum(w * resid[m]) / np.sum(w)
        hold = out[self.hold]
        train = out[self.train]
        return Fit(
            label=label,
            alpha=float(coef[0]),
            beta=np.asarray(coef[1:], dtype=np.float64),
            cov=np.asarray(lsq.cov[: 1 + k, : 1 + k], dtype=np.float64),
            eta=dict(eta),
            residual=out,
            train_rss_w=float(np.sum(self.weights[tr] * lsq.residuals**2)),
            train_rms_um=float(np.sqrt(np.mean(train**2))) if len(train) else float("nan"),
            holdout_rms_um=float(np.sqrt(np.mean(hold**2))) if len(hold) else float("nan"),
            holdout_max_um=float(np.max(np.abs(hold))) if len(hold) else float("nan"),
            n_params=x.shape[1] + len(eta),
            lsq=lsq,
            columns=columns,
        )

    def tolerance_cov(
        self, columns: FloatArray | None, *, nuisance: FloatArray | None = None
    ) -> FloatArray:
        """The covariance (α first, then the columns' amplitudes) the rig's stated tolerances
        add to a fit on the training rows: each tolerance signature (:attr:`nuisance`, or
        ``nuisance``: those about the fitted model, :class:`.tolerances.ModelNuisance`; one
        standard uncertainty of one quantity, independent standard normal in the null world)
        moves the fitted coefficients by the weighted least-squares fit of that signature,
        and those moves add as Σ Δ·Δᵀ. The statistical covariance of :meth:`fit` knows only
        the noise; a rig known to its tolerances is uncertain by this much more."""
        k = 0 if columns is None else columns.shape[1]
        nuis = self.nuisance if nuisance is None else nuisance
        if nuis.shape[1] == 0:
            return np.zeros((1 + k, 1 + k))
        tr = np.flatnonzero(self.train)
        used = np.unique(self.group[tr])
        xs = [self.s[tr, None]]
        if columns is not None:
            xs.append(columns[tr])
        x = np.column_stack([*xs, self.offsets[np.ix_(tr, used)]])
        sw = np.sqrt(self.weights[tr])
        xw = x * sw[:, None]
        scale = np.linalg.norm(xw, axis=0)
        scale[scale == 0] = 1.0
        q, r = np.linalg.qr(xw / scale)
        moves = np.linalg.solve(r, q.T @ (nuis[tr] * sw[:, None])) / scale[:, None]
        d = moves[: 1 + k]
        out: FloatArray = d @ d.T
        return out

    def identifiable(self, columns: FloatArray) -> float:
        """How much of the columns is left once the nominal model (α, offsets) has taken what
        it can, on the training rows: the smallest such fraction over the columns (0: the
        effect is indistinguishable from the nominal model on these runs)."""
        tr = np.flatnonzero(self.train)
        w = np.sqrt(self.weights[tr])
        used = np.unique(self.group[tr])
        base = np.column_stack([self.s[tr], self.offsets[np.ix_(tr, used)]]) * w[:, None]
        q, _ = np.linalg.qr(base / np.linalg.norm(base, axis=0))
        fr = []
        for j in range(columns.shape[1]):
            c = columns[tr, j] * w
            nc = np.linalg.norm(c)
            if nc == 0 or not np.isfinite(nc):
                return 0.0
            fr.append(float(np.linalg.norm(c - q @ (q.T @ c)) / nc))
        return min(fr)

    def profile(
        self, fam: Family, visits: VisitSet | None = None, *, prefix: FloatArray | None = None
    ) -> Fit | None:
        """The family at its best non-linear parameters (least weighted training residual on
        its grid, refined continuously on log scale where the family allows); None if it
        cannot be fitted on these runs. ``prefix``: columns of effects already in the model,
        fitted beside the family's (its non-linear parameters then profiled jointly with
        them)."""
        vs = self.vs if visits is None else visits

        def with_prefix(c: FloatArray) -> FloatArray:
            return c if prefix is None else np.column_stack([prefix, c])

        best: tuple[float, dict[str, float], FloatArray] | None = None
        scores: list[tuple[dict[str, float], float]] = []
        for eta in self.grid(fam):
            try:
                cols = fam.columns(vs, eta)
            except Exception:  # an effect that cannot act on these runs
                return None
            if not np.all(np.isfinite(cols)) or self.identifiable(cols) < 1e-6:
                continue
            f = self._try(with_prefix(cols), eta, fam.label)
            if f is None:
                continue
            scores.append((eta, f.train_rss_w))
            if best is None or f.train_rss_w < best[0]:
                best = (f.train_rss_w, eta, cols)
        if best is None:
            return None
        _, eta, cols = best
        if fam.refine and len(self.grid(fam)) > 2:
            key = fam.refine[0]
            grid = sorted(float(e[key]) for e in self.grid(fam))
            i = grid.index(float(eta[key]))
            lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]

            def rss(logt: float) -> float:
                e = {**eta, key: float(np.exp(logt))}
                c = fam.columns(vs, e)
                f = self._try(with_prefix(c), e, fam.label)
                return np.inf if f is None else f.train_rss_w

            if hi > lo:
                r = minimize_scalar(
                    rss,
                    bounds=(np.log(lo), np.log(hi)),
                    method="bounded",
                    options={"xatol": 0.01},
                )
                if np.isfinite(r.fun) and r.fun <= best[0]:
                    eta = {**eta, key: float(np.exp(r.x))}
                    cols = fam.columns(vs, eta)
        f = self.fit(with_prefix(cols), eta, label=fam.label)
        f.extra["profile"] = scores
        return f

    def profile_ci(
        self,
        fam: Family,
        eta: dict[str, float],
        n_eff: float,
        *,
        prefix: FloatArray | None = None,
        level_chi2: float = 3.841458820694124,
    ) -> tuple[float, float] | None:
        """The profile-likelihood 95 % interval of the family's refined non-linear parameter
        (its time constant) around ``eta``: every value whose weighted training residual,
        the amplitudes (and α, the offsets, ``prefix``'s columns) fitted again at it, stays
        within ``rss_min · (1 + χ²₁,₀.₉₅ / n_eff)`` — the likelihood-ratio test of that value
        with the residual variance estimated from the best fit and the training rows counted
        by their effective number ``n_eff`` (correlated visits). The ends are found by root
        finding on log τ (never a bracket of the search grid); an end that does not close
        within 1/10 … 10× the family's whole grid is that bound, which the JSON then shows;
        the interval may reach below :attr:`min_tau_min`, the shortest time constant a lag
        is named at. None for a family without a refined parameter."""
        if not fam.refine:
            return None
        from scipy.optimize import brentq

        key = fam.refine[0]
        vs = self.vs
        # The whole grid's span: a time constant below :attr:`min_tau_min` is never chosen
        # (not told from the noise's correlation), but the interval is every value the data
        # do not reject, and they may not reject a faster lag.
        grid = sorted(float(e[key]) for e in fam.grid) or [float(eta[key])]
        lo_bound = min(grid[0], float(eta[key])) / 10.0
        hi_bound = max(grid[-1], float(eta[key])) * 10.0
        if key == "half_width_min":
            # A smoother of the readings has a domain (:meth:`grid`): narrower than the
            # analysis' own it does nothing, wider than the shortest thermal time constant it
            # flattens the heating curve. The interval is cut to it, as a bounded parameter's.
            lo_bound = min(2.0 * self.min_tau_min, float(eta[key]))
            hi_bound = max(10.0 * self.min_tau_min, float(eta[key]))

        def rss(logt: float) -> float:
            e = {**eta, key: float(np.exp(logt))}
            try:
                c = fam.columns(vs, e)
            except Exception:  # the effect cannot act at this value
                return np.inf
            if prefix is not None:
                c = np.column_stack([prefix, c])
            f = self._try(c, e, fam.label)
            return np.inf if f is None else f.train_rss_w

        x0 = float(np.log(eta[key]))
        r0 = rss(x0)
        if not np.isfinite(r0):
            return None
        lim = r0 * (1.0 + level_chi2 / max(n_eff, 1.0))

        def excess(x: float) -> float:
            r = rss(x)
            return (r if np.isfinite(r) else 2.0 * lim) - lim

        ends = []
        for sign, bound in ((-1.0, np.log(lo_bound)), (1.0, np.log(hi_bound))):
            inner, x = x0, x0
            found = None
            while sign * (bound - x) > 1e-9:
                x = x0 + sign * min(abs(x - x0) * 1.6 + 0.05, abs(bound - x0))
                if excess(x) > 0:
                    found = brentq(excess, min(inner, x), max(inner, x), xtol=1e-3)
                    break
                inner = x
            ends.append(float(np.exp(found if found is not None else bound)))
        return (min(ends[0], float(eta[key])), max(ends[1], float(eta[key])))

    def grid(self, fam: Family) -> list[dict[str, float]]:
        """The family's grid without time constants below :attr:`min_tau_min`; a smoother of
        the readings (``half_width_min``) wider than the analysis' own (two of them) and at
        most the shortest thermal time constant (ten of them: wider, it flattens the heating
        curve it should follow), and only where the readings scatter by more than the rig's
        stated ``ir_noise_k`` (:attr:`reading_noise_k`)."""
        lo, hi = 2.0 * self.min_tau_min, 10.0 * self.min_tau_min
        # Readings smoothed more only where they scatter by more than the rig states (the
        # null world's readings carry no noise of their own: it cannot weigh a de-noising).
        stated = float(self.vs.rig.tolerances.get("ir_noise_k", 0.0))
        noisy = self.reading_noise_k is not None and self.reading_noise_k > stated
        return [
            e
            for e in fam.grid
            if float(e.get("tau_min", np.inf)) >= self.min_tau_min
            and ("half_width_min" not in e or (noisy and lo < float(e["half_width_min"]) <= hi))
        ]

    def _try(self, cols: FloatArray, eta: dict[str, float], label: str) -> Fit | None:
        try:
            return self.fit(cols, eta, label=label, covariance="iid")
        except (ValueError, np.linalg.LinAlgError):
            return None
