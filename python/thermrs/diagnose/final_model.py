"""The final model: the selected effects fitted together, and every parameter's interval from
that joint fit — amplitudes from its covariance (HAC) and the rig's stated tolerances, a time
constant by profile likelihood, α and the amplitudes widened by how far they move over the
time constant's interval (in quadrature: the marginal interval along the likelihood's ridge).
The same joint fit of each choice of the verdict's effect the data cannot tell from the one
named (another joint, temperature, length or camera), in its place: what the compensation law's
intervals must span.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.candidates import profile_interval
from thermrs.diagnose.family_fit import DesignMatrix, Fit
from thermrs.diagnose.selection import Choice, FamilyGrid, Step

__all__ = ["alternative_fits", "final_model"]

FloatArray = npt.NDArray[np.float64]


def final_model(
    design: DesignMatrix, steps: list[Step], n_eff_train: float
) -> tuple[Fit | None, list[dict[str, Any]]]:
    """The selected effects fitted together (non-linear parameters refined one by one), with
    each effect's parameters from the joint fit: its amplitudes' intervals from the joint
    fit's covariance (HAC) plus what the rig's stated tolerances move them by
    (:meth:`.family_fit.DesignMatrix.tolerance_cov`), its time constant's by profile likelihood
    with the other effects' amplitudes, α and the offsets fitted again at each value, and
    α's from the joint fit and the tolerances likewise (``alpha_per_k``, ``alpha_ci95`` of
    each entry).

    Parameters
    ----------
    design
        The runs' design (training and held-out rows, weights, the rig's tolerances).
    steps
        The forward selection's steps; those with a choice are the model.
    n_eff_train
        The effective number of training rows (the profile likelihood's scale).

    Returns
    -------
    fit, effects
        The joint fit (None when no effect was chosen) and, per effect, ``effect``,
        ``family``, ``params``, ``params_ci95``, ``alpha_per_k`` and ``alpha_ci95``.
    """
    chosen = [s.chosen for s in steps if s.chosen is not None]
    if not chosen:
        return None, []
    cols: list[FloatArray] = []
    eta: dict[str, float] = {}
    sel: list[dict[str, Any]] = []
    for ch in chosen:
        fam = ch.grid.family
        fixed = np.column_stack(cols) if cols else None
        best = design.profile(fam, prefix=fixed)
        use_eta = best.eta if best is not None else ch.eta
        c = fam.columns(design.vs, use_eta)
        cols.append(c)
        eta.update({f"{fam.effect}.{k}": v for k, v in use_eta.items()})
        sel.append({"family": fam, "eta": use_eta, "width": c.shape[1]})
    x = np.column_stack(cols)
    f = design.fit(x, eta, label=" + ".join(s["family"].label for s in sel))
    # The parameters' intervals carry the noise (the fit's HAC covariance) and the rig's
    # stated tolerances (what they move the fitted coefficients by).
    # About this model: its effects read the IR camera too (.tolerances.ModelNuisance).
    nuis = None
    if design.model_nuisance is not None and design.nuisance.shape[1]:
        terms = [(s["family"], s["eta"], c) for s, c in zip(sel, cols, strict=True)]
        nuis = design.model_nuisance.of(terms, np.concatenate([[f.alpha], f.beta]))
    cov = f.cov + design.tolerance_cov(x, nuisance=nuis)
    if nuis is not None:
        f.extra["nuisance"] = nuis
    f.extra["terms"] = [(s["family"], s["eta"], c) for s, c in zip(sel, cols, strict=True)]
    alpha_ci = _alpha_interval(f, cov)
    out: list[dict[str, Any]] = []
    ends: list[tuple[int, dict[str, float]]] = []
    first = 0
    for j, s in enumerate(sel):
        fam = s["family"]
        k = s["width"]
        idx = [0, *range(1 + first, 1 + first + k)]
        params, ci = fam.params(s["eta"], f.alpha, f.beta[first : first + k], cov[np.ix_(idx, idx)])
        others = [c for i, c in enumerate(cols) if i != j]
        prefix = np.column_stack(others) if others else None
        probe = Fit(fam.label, f.alpha, f.beta, f.cov, dict(s["eta"]), f.residual, 0.0,
                    0.0, 0.0, 0.0, 0)  # fmt: skip
        prof = profile_interval(design, fam, probe, n_eff_train, prefix=prefix)
        ci = {**ci, **prof}
        for key, (lo, hi) in prof.items():
            ends += [(j, {**s["eta"], key: float(lo)}), (j, {**s["eta"], key: float(hi)})]
        out.append({"effect": fam.effect, "family": fam.label, "params": params, "params_ci95": ci})
        first += k
    alpha_ci = _over_time_constants(design, f, alpha_ci, cols, sel, eta, ends, out)
    for o in out:
        o["alpha_per_k"] = f.alpha
        o["alpha_ci95"] = [float(alpha_ci[0]), float(alpha_ci[1])]
    return f, out


def _over_time_constants(
    design: DesignMatrix,
    f: Fit,
    alpha_ci: tuple[float, float],
    cols: list[FloatArray],
    sel: list[dict[str, Any]],
    eta: dict[str, float],
    ends: list[tuple[int, dict[str, float]]],
    out: list[dict[str, Any]],
) -> tuple[float, float]:
    """α's interval, and each effect's amplitudes' in ``out``, widened by how far they move
    over its time constant's interval (``ends``: the effect's index and η at each end)."""
    # α and the amplitudes are fitted at the time constants found; over a time constant's
    # interval they move with it (a slow lag trades with α). How far they move at its 95 %
    # ends is added in quadrature to their intervals at the value found: along the
    # likelihood's ridge that is the marginal interval (exactly, for a Gaussian likelihood);
    # their union with the intervals at the ends would count both 95 % extremes at once.
    alpha_shift = [0.0, 0.0]
    at_ends: dict[int, list[dict[str, Any]]] = {}
    for j, eta_end in ends:
        cols_end = list(cols)
        cols_end[j] = sel[j]["family"].columns(design.vs, eta_end)
        try:
            f_end = design.fit(np.column_stack(cols_end), eta, label="profile end")
        except (ValueError, np.linalg.LinAlgError):
            continue
        d = f_end.alpha - f.alpha
        alpha_shift[int(d > 0)] = max(alpha_shift[int(d > 0)], abs(d))
        first = sum(s["width"] for s in sel[:j])
        k = sel[j]["width"]
        idx = [0, *range(1 + first, 1 + first + k)]
        p_end, ci_end = sel[j]["family"].params(
            eta_end, f_end.alpha, f_end.beta[first : first + k], f_end.cov[np.ix_(idx, idx)]
        )
        at_ends.setdefault(j, []).append(_centres(p_end, ci_end))
    for j, p_ends in at_ends.items():
        refined = set(sel[j]["family"].refine)
        centre = _centres(out[j]["params"], out[j]["params_ci95"])
        out[j]["params_ci95"] = {
            key: c if key in refined else _widened(c, centre.get(key), [p.get(key) for p in p_ends])
            for key, c in out[j]["params_ci95"].items()
        }  # fmt: skip
    alpha_ci = (
        f.alpha - float(np.hypot(f.alpha - alpha_ci[0], alpha_shift[0])),
        f.alpha + float(np.hypot(alpha_ci[1] - f.alpha, alpha_shift[1])),
    )
    return alpha_ci


def _alpha_interval(f: Fit, cov: FloatArray) -> tuple[float, float]:
    """α's 95 % interval of a fit: its own (HAC, Student t) widened in quadrature by the rig's
    tolerances' share (``cov`` less the fit's own covariance)."""
    lo, hi = f.lsq.interval(0) if f.lsq is not None else (np.nan, np.nan)
    half = float(np.hypot((hi - lo) / 2.0, 1.96 * np.sqrt(max(cov[0, 0] - f.cov[0, 0], 0.0))))
    return (f.alpha - half, f.alpha + half)


def _centres(params: dict[str, Any], ci: dict[str, Any]) -> dict[str, Any]:
    """``params`` with, for each interval of ``ci`` that has no parameter of its own (a
    lag's weight), the interval's midpoint (the intervals are symmetric about it)."""
    return {**{k: float(np.mean(c)) for k, c in ci.items() if k not in params
               and isinstance(c, list | tuple) and len(c) == 2
               and all(isinstance(v, int | float) for v in c)}, **params}  # fmt: skip


def _widened(ci: Any, centre: Any, ends: list[Any]) -> Any:
    """An interval (or a list or dict of them, as ``centre`` is a number, list or dict) whose
    lower and upper half-widths take in, in quadrature, how far below and above ``centre``
    the values ``ends`` lie."""
    if isinstance(centre, dict) and isinstance(ci, dict):
        return {
            k: _widened(c, centre[k], [e.get(k) if isinstance(e, dict) else None for e in ends])
            if k in centre else c
            for k, c in ci.items()
        }  # fmt: skip
    if isinstance(centre, list | tuple) and isinstance(ci, list | tuple) and len(ci) == len(centre):
        return [
            _widened(c, x, [e[i] if isinstance(e, list | tuple) else None for e in ends])
            for i, (c, x) in enumerate(zip(ci, centre, strict=True))
        ]
    if not isinstance(centre, int | float) or not isinstance(ci, list | tuple) or len(ci) != 2:
        return ci
    vals = [float(e) for e in ends if isinstance(e, int | float) and np.isfinite(e)]
    down = max([centre - v for v in vals] + [0.0])
    up = max([v - centre for v in vals] + [0.0])
    return [
        float(centre - np.hypot(centre - ci[0], down)),
        float(centre + np.hypot(ci[1] - centre, up)),
    ]


def alternative_fits(
    design: DesignMatrix,
    steps: list[Step],
    n_eff_train: float,
    grids: list[FamilyGrid],
    labels: list[str],
) -> list[dict[str, Any]]:
    """The first selected effect's alternative choices (family ``labels``: those the data
    cannot reject as the truth), each fitted jointly in its place as :func:`final_model` fits
    the effect named: per alternative its ``family``, ``params``, ``params_ci95``,
    ``alpha_per_k`` and ``alpha_ci95``. An alternative the design cannot fit is left out."""
    first = next((s for s in steps if s.chosen is not None), None)
    by_label = {g.family.label: g for g in grids}
    out: list[dict[str, Any]] = []
    if first is None:
        return out
    for label in labels:
        grid = by_label.get(label)
        if grid is None:
            continue
        alt = [replace(s, chosen=Choice(grid, 0)) if s is first else s for s in steps]
        try:
            _, sel = final_model(design, alt, n_eff_train)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if sel:
            keys = ("family", "params", "params_ci95", "alpha_per_k", "alpha_ci95")
            out.append({k: sel[0][k] for k in keys})
    return out
