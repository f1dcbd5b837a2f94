"""Diagnose the sim-to-real gap: where the nominal model's residual lies, which unmodelled
effect (SPEC §6) causes it, and how far it shrinks once that effect is added — scored on runs
the fits never saw.

The procedure (see ``shared/notes/diagnosis.md`` for the field's tools and their traps):

1. **Baseline.** α and the per-(run, camera, axis) offsets of the nominal model fitted on the
   training runs (:mod:`thermrs.diagnose.engine`); the held-out runs get only their offsets.
   The noise floor is the measurement's own visit-to-visit repeatability, from a variogram of
   the residual series (:mod:`thermrs.diagnose.location`).
2. **Where.** The residual by run, camera, chip axis and phase, its correlation with every
   driver, a whiteness test.
3. **Which.** Every effect family (:meth:`thermrs.effects.Effect.families`) fitted on the
   training runs with its non-linear parameters profiled, scored on the held-out runs: RMS and
   shrink; the held-out gain's z-score against a moving-block bootstrap of the per-visit
   squared-error differences (autocorrelation kept); ΔAICc on the effective sample size;
   stability (how often it is the best fit on block-bootstrap resamples of the training
   visits); a placebo (its signature computed from drivers shifted by half of each series,
   which keeps their smoothness, must gain far less); plausibility (a structural effect's
   amplitude must agree with α). Near-collinear candidates (largest canonical correlation of
   their signatures, with the nominal model projected out, above 0.9) are *confounded*; the
   runs, cameras or axes on which they differ most name the measurement that separates them.
   Effects are added greedily while the held-out gain stays significant.
4. **Verdict.** ``identified``: one effect with a significant held-out gain that closes at
   least half of the gap above the noise floor, beats its placebo, is plausible and has no
   rival it cannot be told from. ``ambiguous``: such a gain but rivals that explain it as well
   (named). ``unexplained``: a residual above the floor that no candidate removes enough of.
   ``none``: the held-out residual within 8 % of the noise floor (what is above it is too
   little to attribute, whatever a candidate gains).
5. **How far.** Held-out RMS and maximum before and after; the gap closed as a fraction of the
   gap above the floor.

Example
-------
>>> import thermrs
>>> from thermrs.diagnose import diagnose
>>> # d = diagnose([train_table], [holdout_table], thermrs.load_rig())
>>> # d.verdict["status"], d.to_json()["ranking"][0]["effect"]
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.diagnose.engine import Design, Fit
from thermrs.diagnose.location import drivers, location_table, noise_floor, phases, whiteness
from thermrs.effects import EFFECT_NAMES, Effect, Family, effect_classes
from thermrs.errors import InputError
from thermrs.rig import Rig
from thermrs.signatures import VisitSet
from thermrs.stats import effective_sample_size

__all__ = ["Diagnosis", "diagnose"]

FloatArray = npt.NDArray[np.float64]

#: z-score the held-out gain of an effect must reach (block bootstrap).
GAIN_Z = 3.0
#: Least relative drop of the held-out RMS an effect must bring.
MIN_REL_GAIN = 0.03
#: Least fraction of the gap above the noise floor an identified effect must close.
MIN_GAP_CLOSED = 0.5
#: Largest share of an effect's held-out gain its placebo may reach.
PLACEBO_SHARE = 0.5
#: Canonical correlation above which two signatures are confounded on the given runs.
CONFOUND_COS = 0.9
#: A held-out residual above this multiple of the noise floor is structured (the floor's own
#: estimate scatters by 2–3 % between seeds of the bench; effect-free bench cases sit at
#: 1.01–1.05).
STRUCTURED = 1.08
#: A rival is not significantly worse than the best on the held-out runs: its extra squared
#: error is below this many block-bootstrap standard errors.
RIVAL_Z = 3.0
#: Amplitude ratio (fitted / α) a structural effect must show to be plausible.
WEIGHT_RANGE = (0.25, 4.0)


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`: see :meth:`to_json` for every field (SPEC §7)."""

    noise_floor_um: float
    baseline: dict[str, Any]
    location: list[dict[str, Any]]
    drivers: list[dict[str, Any]]
    whiteness: dict[str, Any]
    ranking: list[dict[str, Any]]
    confounded: list[dict[str, Any]]
    verdict: dict[str, Any]
    how_far: dict[str, Any]
    selected: list[dict[str, Any]]
    library: list[str]
    excluded: list[str]
    summary: str
    residuals: pl.DataFrame = field(repr=False)

    @property
    def status(self) -> str:
        """The verdict: ``identified``, ``ambiguous``, ``unexplained`` or ``none``."""
        return str(self.verdict["status"])

    def to_json(self) -> dict[str, Any]:
        """The SPEC §7 ``thermrs diagnose --json`` document (extended)."""
        return {
            "noise_floor_um": self.noise_floor_um,
            "baseline": self.baseline,
            "location": self.location,
            "drivers": self.drivers,
            "whiteness": self.whiteness,
            "ranking": self.ranking,
            "confounded": self.confounded,
            "selected": self.selected,
            "verdict": self.verdict,
            "how_far": self.how_far,
            "library": self.library,
            "excluded": self.excluded,
            "summary": self.summary,
        }


def _block_se(
    d: FloatArray,
    groups: npt.NDArray[np.str_],
    order: FloatArray,
    rng: np.random.Generator,
    *,
    block: int = 20,
    draws: int = 200,
) -> float:
    """Standard error of mean(d) by a moving-block bootstrap within each series."""
    series = []
    for g in np.unique(groups):
        idx = np.flatnonzero(groups == g)
        series.append(d[idx[np.argsort(order[idx])]])
    means = np.empty(draws)
    for b in range(draws):
        tot = 0.0
        cnt = 0
        for s in series:
            m = len(s)
            L = min(block, m)
            nb = int(np.ceil(m / L))
            starts = rng.integers(0, m - L + 1, nb)
            pick = np.concatenate([s[st : st + L] for st in starts])[:m]
            tot += float(pick.sum())
            cnt += m
        means[b] = tot / max(cnt, 1)
    return float(np.std(means, ddof=1))


def _residualised(design: Design, cols: FloatArray) -> FloatArray:
    """Columns with the nominal model (α column and offsets) projected out, weighted, on
    every row; unit-norm."""
    w = np.sqrt(design.weights)
    base = np.column_stack([design.s, design.offsets]) * w[:, None]
    q, _ = np.linalg.qr(base / np.maximum(np.linalg.norm(base, axis=0), 1e-300))
    c = cols * w[:, None]
    c = c - q @ (q.T @ c)
    n = np.linalg.norm(c, axis=0)
    return c / np.where(n > 0, n, 1.0)


def _canonical_cos(a: FloatArray, b: FloatArray) -> float:
    """Largest canonical correlation between two column spaces."""
    qa, _ = np.linalg.qr(a)
    qb, _ = np.linalg.qr(b)
    return float(np.clip(np.linalg.svd(qa.T @ qb, compute_uv=False)[0], 0.0, 1.0))


#: What separates two effects whose drivers differ, by driver kind.
_DRIVER_HINT = {
    "time": "a run that starts warm or a cool-down (time since the start keeps rising while the "
    "temperatures fall)",
    "ambient": "an ambient step or a run on another day (the mount follows ambient, the links "
    "follow the robot's own heat)",
    "geometry": "another pose or camera (a tilted laser changes the throw-amplified term)",
}


def _separate_by(design: Design, a: FloatArray, b: FloatArray, da: str, db: str) -> str:
    """Where on the given runs two signatures differ most, and what would separate them."""
    vs = design.vs
    run2 = np.concatenate([vs.run, vs.run])
    cam2 = np.concatenate([vs.camera, vs.camera])
    subsets: list[tuple[str, npt.NDArray[np.bool_]]] = []
    for r in np.unique(run2):
        subsets.append((f"run {r}", run2 == r))
    for c in np.unique(cam2):
        for ax in ("u", "v"):
            subsets.append((f"camera {c} chip axis {ax}", (cam2 == c) & (vs.axis == ax)))
    best: tuple[float, str] | None = None
    for label, m in subsets:
        if m.sum() < 10:
            continue
        sa, sb = a[m], b[m]
        if np.linalg.norm(sa) < 1e-9 or np.linalg.norm(sb) < 1e-9:
            continue
        c = _canonical_cos(sa, sb)
        if best is None or c < best[0]:
            best = (c, label)
    parts = []
    if best is not None and best[0] < CONFOUND_COS:
        parts.append(f"they differ most on {best[1]} (canonical correlation {best[0]:.2f} there)")
    kinds = {
        da if da in _DRIVER_HINT else "temperature",
        db if db in _DRIVER_HINT else "temperature",
    }
    for k in ("time", "ambient", "geometry"):
        if k in kinds and len(kinds) > 1:
            parts.append(_DRIVER_HINT[k])
    if not parts:
        parts.append(
            "a run at another speed (a different ratio of the links' temperatures) or a "
            "cool-down (a different sign and time constant)"
        )
    return "; ".join(parts)


def _check_runs(tables: Sequence[pl.DataFrame], what: str) -> list[pl.DataFrame]:
    if isinstance(tables, pl.DataFrame):
        tables = [tables]
    out = []
    for t in tables:
        if not isinstance(t, pl.DataFrame):
            raise TypeError(
                f"{what} runs must be run tables (polars DataFrames), got {type(t).__name__}"
            )
        for c in ("run", "camera", "t_ns", "u_um", "v_um"):
            if c not in t.columns:
                raise InputError(
                    f"a {what} run table has no `{c}` column (see thermrs.fit.run_table)"
                )
        if t.filter(pl.col("u_um").is_finite()).height == 0:
            name = t["run"][0] if t.height else "?"
            raise InputError(f"{what} run {name!r} has no visits with a spot")
        out.append(t)
    return out


def diagnose(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig,
    *,
    exclude: Sequence[str] = (),
    library: Sequence[type[Effect]] | None = None,
    bootstrap: int = 30,
    seed: int = 0,
    progress: Callable[[str], object] | None = None,
) -> Diagnosis:
    """Diagnose the nominal model's gap on ``holdout`` runs after fitting on ``train`` runs.

    Parameters
    ----------
    train, holdout
        Run tables (:func:`thermrs.fit.load_run_table`); at least one of each, with distinct
        ``run`` names. Fits use only ``train``; ``holdout`` runs contribute only their own
        offsets (unknown mountings).
    rig
        The rig (nominal model).
    exclude
        SPEC §6 effect names the diagnoser may not name (a withheld-effect check).
    library
        Effect classes to consider (default: every registered one,
        :func:`thermrs.effects.effect_classes`).
    bootstrap
        Block-bootstrap resamples of the training visits for the stability score.
    seed
        Seed of the bootstrap draws.
    progress
        Called with a short message at each stage.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        No training or no held-out run, a run used twice, a run without visits, an unknown
        effect name in ``exclude``.
    """
    from threadpoolctl import threadpool_limits  # type: ignore[import-untyped]

    # Thousands of small least-squares problems: one BLAS thread each is several times faster
    # than a pool that spins (and fights other processes for the cores).
    with threadpool_limits(limits=1, user_api="blas"):
        return _diagnose(
            train,
            holdout,
            rig,
            exclude=exclude,
            library=library,
            bootstrap=bootstrap,
            seed=seed,
            progress=progress,
        )


def _diagnose(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig,
    *,
    exclude: Sequence[str],
    library: Sequence[type[Effect]] | None,
    bootstrap: int,
    seed: int,
    progress: Callable[[str], object] | None,
) -> Diagnosis:
    say = progress or (lambda _m: None)
    if isinstance(rig, (str,)) or not isinstance(rig, Rig):
        raise TypeError(
            f"rig must be a thermrs.Rig (thermrs.load_rig(path)), got {type(rig).__name__}"
        )
    train = _check_runs(train, "training")
    holdout = _check_runs(holdout, "held-out")
    if not train:
        raise InputError(
            "no training run: the nominal model and each effect are fitted on --train runs"
        )
    if not holdout:
        raise InputError(
            "no held-out run: effects are scored on runs they were not fitted on (give --holdout)"
        )
    names_t = [str(n) for t in train for n in t["run"].unique().to_list()]
    names_h = [str(n) for t in holdout for n in t["run"].unique().to_list()]
    both = sorted(set(names_t) & set(names_h))
    if both or len(set(names_t)) != len(names_t) or len(set(names_h)) != len(names_h):
        raise InputError(
            "run names must be distinct across --train and --holdout "
            f"(repeated: {both or 'within one side'})"
        )
    classes = dict(effect_classes()) if library is None else {c.name: c for c in library}
    unknown = sorted(set(exclude) - set(classes) - set(EFFECT_NAMES))
    if unknown:
        raise InputError(f"--exclude {unknown}: not effects (known: {', '.join(EFFECT_NAMES)})")
    # Excluded effects may not be named; their signatures still count as rivals, so that an
    # effect confounded with one of them is never reported as identified.
    hidden = set(exclude)
    rng = np.random.default_rng(seed)

    say("baseline")
    tables = [*train, *holdout]
    vs = VisitSet(tables, rig)
    design = Design(vs, set(names_t))
    base = design.fit(None, {}, label="nominal")
    groups3 = np.char.add(np.char.add(design.series, "/"), vs.axis)
    floor = noise_floor(vs, base.residual, groups3)
    role_visit = np.where(np.isin(vs.run, names_t), "train", "holdout")
    role2 = np.concatenate([role_visit, role_visit])
    phase = phases(vs, rig.mapped_temperatures)
    hold = design.hold
    n_eff_train = float(
        sum(
            effective_sample_size(base.residual[(groups3 == g)], method="ar1")
            for g in np.unique(groups3[design.train])
        )
    )

    say("where")
    loc = location_table(vs, base.residual, phase, role_visit)
    drv = drivers(vs, base.residual)
    white = whiteness(base.residual[hold], groups3[hold], design.order[hold])

    say("which")
    fams: list[Family] = []
    for cls in classes.values():
        fams.extend(cls.families(rig, vs))
    fits: list[tuple[Family, Fit]] = []
    for fam in fams:
        f = design.profile(fam)
        if f is not None:
            fits.append((fam, f))
    placebo_vs = VisitSet(tables, rig, shift_drivers=True)

    def gain_stats(f: Fit, ref: Fit) -> tuple[float, float]:
        d = ref.residual[hold] ** 2 - f.residual[hold] ** 2
        se = _block_se(d, groups3[hold], design.order[hold], rng, draws=100)
        return float(d.mean()), se

    scored: list[dict[str, Any]] = []
    for fam, f in fits:
        mean_gain, se = gain_stats(f, base)
        z = mean_gain / se if se > 0 else 0.0
        gap = base.holdout_rms_um - floor
        closed = (base.holdout_rms_um - f.holdout_rms_um) / gap if gap > 0 else None
        assert f.columns is not None
        params, ci = fam.params(f.eta, f.alpha, f.beta, f.cov)
        k = f.n_params - 1 - design.offsets.shape[1]
        n = max(n_eff_train, k + 3.0)
        n_rows = float(design.train.sum())

        def aicc(rss: float, p: int, n: float = n, n_rows: float = n_rows) -> float:
            pen = 2 * p + 2 * p * (p + 1) / max(n - p - 1, 1.0)
            return float(n * np.log(rss / n_rows) + pen)

        d_aicc = aicc(f.train_rss_w, 1 + k) - aicc(base.train_rss_w, 1)
        plausible = True
        w = ci.get("weight")
        if w is not None:
            wv = float(np.mean(w))
            plausible = WEIGHT_RANGE[0] <= wv <= WEIGHT_RANGE[1]
        try:  # the fitted effect must be physically possible (the core's bounds)
            from thermrs.effects import from_dict as _from_dict

            full = {"name": fam.effect, **params}
            if fam.effect in EFFECT_NAMES:
                _from_dict(full, rig=rig)
        except (InputError, TypeError):
            plausible = False
        scored.append(
            {
                "family": fam,
                "fit": f,
                "params": params,
                "ci": ci,
                "gain": mean_gain,
                "z": z,
                "closed": closed,
                "d_aicc": d_aicc,
                "plausible": plausible,
                "identifiable": design.identifiable(f.columns),
            }
        )
    scored.sort(key=lambda s: s["fit"].holdout_rms_um)

    # Placebos and stability for the leading candidates (one per effect name).
    top_all: list[dict[str, Any]] = []
    seen: set[str] = set()
    for s in scored:
        if s["family"].effect not in seen:
            seen.add(s["family"].effect)
            top_all.append(s)
    top = [s for s in top_all if s["family"].effect not in hidden]
    say("placebos")
    for s in top_all:
        fam, f = s["family"], s["fit"]
        try:
            pc = fam.columns(placebo_vs, f.eta)
            pf = design.fit(pc, f.eta, label="placebo", covariance="iid")
            s["placebo_rms"] = pf.holdout_rms_um
            s["placebo_gain"] = float(np.mean(base.residual[hold] ** 2 - pf.residual[hold] ** 2))
        except (ValueError, np.linalg.LinAlgError, InputError):
            s["placebo_rms"] = None
            s["placebo_gain"] = None
    say("stability")
    lead = top[: min(5, len(top))]
    wins = dict.fromkeys(range(len(lead)), 0)
    units = np.flatnonzero(design.train[: vs.n])
    if lead and bootstrap > 0:
        series_v = design.series[: vs.n]
        for _ in range(bootstrap):
            pick = []
            for g in np.unique(series_v[units]):
                idx = units[series_v[units] == g]
                m = len(idx)
                L = min(20, m)
                starts = rng.integers(0, m - L + 1, int(np.ceil(m / L)))
                pick.append(np.concatenate([idx[s : s + L] for s in starts])[:m])
            vis = np.concatenate(pick)
            rows = np.concatenate([vis, vis + vs.n])
            rss = []
            for s in lead:
                try:
                    bf = design.fit(
                        s["fit"].columns, s["fit"].eta, label="b", rows=rows, covariance="iid"
                    )
                    rss.append(bf.train_rss_w)
                except (ValueError, np.linalg.LinAlgError):
                    rss.append(np.inf)
            wins[int(np.argmin(rss))] += 1
        for i, s in enumerate(lead):
            s["stability"] = wins[i] / bootstrap
    base_rms = base.holdout_rms_um

    def qualifies(s: dict[str, Any]) -> bool:
        f = s["fit"]
        rel = 1.0 - f.holdout_rms_um / base_rms if base_rms > 0 else 0.0
        placebo_ok = s.get("placebo_gain") is None or s["placebo_gain"] <= PLACEBO_SHARE * s["gain"]
        return bool(s["z"] >= GAIN_Z and rel >= MIN_REL_GAIN and placebo_ok and s["plausible"])

    # Confounding among the candidates that qualify (or the leading three).
    say("confounding")
    pool = [s for s in top if qualifies(s)] or top[:3]
    res_cols = {id(s): _residualised(design, s["fit"].columns) for s in pool}
    confounded: list[dict[str, Any]] = []
    for i, a in enumerate(pool):
        for b in pool[i + 1 :]:
            c = _canonical_cos(res_cols[id(a)], res_cols[id(b)])
            if c >= CONFOUND_COS:
                confounded.append(
                    {
                        "effects": [a["family"].effect, b["family"].effect],
                        "families": [a["family"].label, b["family"].label],
                        "cos": c,
                        "separate_by": _separate_by(
                            design,
                            res_cols[id(a)],
                            res_cols[id(b)],
                            a["family"].driver,
                            b["family"].driver,
                        ),
                    }
                )

    # Verdict.
    structured = base_rms > STRUCTURED * floor
    good = [s for s in top if qualifies(s)]
    good_all = [s for s in top_all if qualifies(s)]
    status = "none"
    chosen: dict[str, Any] | None = None
    rivals: list[str] = []
    reason = ""
    if good:
        best = good[0]
        closed = best["closed"] if best["closed"] is not None else 0.0
        # Rivals: other qualifying effects whose held-out errors are not significantly worse.
        hidden_rival = False
        for s in good_all:
            if s is best:
                continue
            d = s["fit"].residual[hold] ** 2 - best["fit"].residual[hold] ** 2
            se = _block_se(d, groups3[hold], design.order[hold], rng, draws=100)
            if d.mean() < RIVAL_Z * se:
                if s["family"].effect in hidden:
                    hidden_rival = True
                else:
                    rivals.append(s["family"].effect)
        conf_names = {
            e for c in confounded if best["family"].effect in c["effects"] for e in c["effects"]
        } - {best["family"].effect}
        if not structured:
            status = "none"
            reason = (
                f"the held-out residual ({base_rms:.2f} µm) is within {STRUCTURED - 1:.0%} of the "
                f"noise floor ({floor:.2f} µm): too close to it to attribute; the best "
                f"candidate, {best['family'].label}, would take it to "
                f"{best['fit'].holdout_rms_um:.2f} µm"
            )
        elif closed < MIN_GAP_CLOSED:
            status = "unexplained"
            reason = (
                f"the best candidate, {best['family'].label}, closes only {closed:.0%} of the gap "
                "above the noise floor on the held-out runs"
            )
        elif rivals or hidden_rival:
            status = "ambiguous"
            chosen = best
            rivals = sorted(set(rivals) | (conf_names & {s["family"].effect for s in good}))
            names = [
                best["family"].effect,
                *rivals,
                *(["an effect excluded from the library"] if hidden_rival else []),
            ]
            listed = ", ".join(names[:-1]) + " and " + names[-1]
            reason = f"{listed} explain the held-out runs about equally well"
        else:
            status = "identified"
            chosen = best
            reason = (
                f"{best['family'].label} closes {closed:.0%} of the gap above the noise floor on "
                f"the held-out runs (z = {best['z']:.1f}), beats its placebo and every other "
                "candidate"
            )
    elif structured:
        status = "unexplained"
        reason = (
            f"the held-out residual ({base_rms:.2f} µm) is above the noise floor ({floor:.2f} µm) "
            "and no candidate removes a significant part of it"
        )
    else:
        reason = (
            f"the held-out residual ({base_rms:.2f} µm) is at the noise floor ({floor:.2f} µm) "
            "and no candidate has a significant held-out gain"
        )

    # Greedy: add further effects while the held-out gain stays significant.
    selected: list[dict[str, Any]] = []
    final = base
    if chosen is not None:
        selected.append(chosen)
        final = chosen["fit"]
        for s in good:
            if s is chosen or s["family"].effect in rivals:
                continue
            assert final.columns is not None
            cols = np.column_stack([final.columns, s["fit"].columns])
            eta = {**final.eta, **{f"{s['family'].effect}.{k}": v for k, v in s["fit"].eta.items()}}
            try:
                f2 = design.fit(cols, eta, label=final.label + " + " + s["family"].label)
            except (ValueError, np.linalg.LinAlgError):
                continue
            mg, se = gain_stats(f2, final)
            if (
                se > 0
                and mg / se >= GAIN_Z
                and f2.holdout_rms_um <= (1 - MIN_REL_GAIN) * final.holdout_rms_um
            ):
                selected.append(s)
                final = f2
            if len(selected) >= 3:
                break

    def row(s: dict[str, Any]) -> dict[str, Any]:
        f = s["fit"]
        ci = dict(s["ci"])
        prof = f.extra.get("profile") or []
        if s["family"].refine and prof:
            key = s["family"].refine[0]
            best_rss = min(r for _, r in prof)
            lim = best_rss * (1.0 + 3.84 / max(n_eff_train, 1.0))
            ok = [e[key] for e, r in prof if r <= lim] + [f.eta[key]]
            ci[key] = [float(min(ok)), float(max(ok))]
        return {
            "effect": s["family"].effect,
            "family": s["family"].label,
            "params": s["params"],
            "params_ci95": ci,
            "alpha_per_k": f.alpha,
            "train_rms_um": f.train_rms_um,
            "holdout_rms_um": f.holdout_rms_um,
            "holdout_max_um": f.holdout_max_um,
            "shrink": 1.0 - f.holdout_rms_um / base_rms if base_rms > 0 else 0.0,
            "evidence": {
                "gain_z": s["z"],
                "gap_closed": s["closed"],
                "delta_aicc": s["d_aicc"],
                "n_eff": n_eff_train,
                "stability": s.get("stability"),
                "placebo_holdout_rms_um": s.get("placebo_rms"),
                "placebo_beaten": (
                    None
                    if s.get("placebo_gain") is None
                    else bool(s["placebo_gain"] <= PLACEBO_SHARE * s["gain"])
                ),
                "plausible": s["plausible"],
                "identifiable": s["identifiable"],
                "qualifies": qualifies(s),
            },
        }

    ranking = [row(s) for s in top]
    gap = base_rms - floor
    how_far = {
        "holdout_rms_before_um": base_rms,
        "holdout_rms_after_um": final.holdout_rms_um,
        "holdout_max_before_um": base.holdout_max_um,
        "holdout_max_after_um": final.holdout_max_um,
        "noise_floor_um": floor,
        "gap_closed": (base_rms - final.holdout_rms_um) / gap
        if gap > 0 and final is not base
        else (0.0 if gap > 0 else None),
    }
    verdict = {
        "status": status,
        "effect": None if chosen is None else chosen["family"].effect,
        "params": {} if chosen is None else chosen["params"],
        "params_ci95": {} if chosen is None else row(chosen)["params_ci95"],
        "confounded_with": rivals if status == "ambiguous" else [],
        "holdout_rms_um": final.holdout_rms_um if chosen is not None else base_rms,
        "reason": reason,
    }
    baseline = {
        "alpha_per_k": {
            "value": base.alpha,
            "ci95": list(base.lsq.interval(0) if base.lsq is not None else (np.nan, np.nan)),
        },
        "train_rms_um": base.train_rms_um,
        "holdout_rms_um": base_rms,
        "holdout_max_um": base.holdout_max_um,
        "per_run": _per_run(vs, base.residual, role_visit),
    }
    t_h = (np.concatenate([vs.t_since_start, vs.t_since_start])) / 3600.0
    residuals = pl.DataFrame(
        {
            "run": np.concatenate([vs.run, vs.run]),
            "role": role2,
            "camera": np.concatenate([vs.camera, vs.camera]),
            "axis": vs.axis,
            "t_ns": np.concatenate([vs.table["t_ns"].to_numpy()] * 2),
            "t_h": t_h,
            "phase": np.concatenate([phase, phase]),
            "baseline_um": base.residual,
            "after_um": final.residual if chosen is not None else np.full(2 * vs.n, np.nan),
        }
    ).with_columns(pl.col("after_um").fill_nan(None))
    sel = [
        {"effect": s["family"].effect, "family": s["family"].label, "params": s["params"]}
        for s in selected
    ]
    d = Diagnosis(
        noise_floor_um=floor,
        baseline=baseline,
        location=loc,
        drivers=drv[:20],
        whiteness=white,
        ranking=ranking,
        confounded=confounded,
        verdict=verdict,
        how_far=how_far,
        selected=sel,
        library=sorted(set(classes) - hidden),
        excluded=sorted(exclude),
        summary="",
        residuals=residuals,
    )
    d.summary = _summary(d)
    return d


def _per_run(
    vs: VisitSet, residual: FloatArray, role: npt.NDArray[np.str_]
) -> list[dict[str, Any]]:
    out = []
    run2 = np.concatenate([vs.run, vs.run])
    cam2 = np.concatenate([vs.camera, vs.camera])
    for r in dict.fromkeys(vs.run.tolist()):
        for c in dict.fromkeys(vs.camera.tolist()):
            for ax in ("u", "v"):
                m = (run2 == r) & (cam2 == c) & (vs.axis == ax)
                if m.any():
                    out.append(
                        {
                            "run": r,
                            "role": str(role[vs.run == r][0]),
                            "camera": c,
                            "axis": ax,
                            "rms_um": float(np.sqrt(np.mean(residual[m] ** 2))),
                        }
                    )
    return out


def _summary(d: Diagnosis) -> str:
    v = d.verdict
    hf = d.how_far
    head = (
        "The nominal model, fitted on the training runs, leaves "
        f"{hf['holdout_rms_before_um']:.2f} µm "
        f"rms on the held-out runs against a noise floor of {d.noise_floor_um:.2f} µm."
    )
    worst = max(d.location, key=lambda r: r["share"]) if d.location else None
    where = (
        f" The largest share ({worst['share']:.0%}) lies on run {worst['run']}, camera "
        f"{worst['camera']}, chip axis {worst['axis']}, {worst['phase']}."
        if worst
        else ""
    )
    if v["status"] == "identified":
        what = (
            f" Verdict: identified — {v['effect']} ({_fmt_params(v['params'])}); with it the "
            f"held-out rms falls to {hf['holdout_rms_after_um']:.2f} µm, closing "
            f"{(hf['gap_closed'] or 0):.0%} of the gap above the floor."
        )
    elif v["status"] == "ambiguous":
        what = f" Verdict: ambiguous — {v['reason']} on these runs."
        sep = [c["separate_by"] for c in d.confounded if v["effect"] in c["effects"]]
        if sep:
            what += f" To tell them apart: {sep[0]}."
    elif v["status"] == "unexplained":
        what = f" Verdict: unexplained — {v['reason']}."
    else:
        what = f" Verdict: none — {v['reason']}."
    return head + where + what


def _fmt_params(p: dict[str, Any]) -> str:
    parts = []
    for k, v in p.items():
        if isinstance(v, float):
            parts.append(f"{k} = {v:.4g}")
        elif isinstance(v, list):
            parts.append(f"{k} = [{', '.join(f'{x:.3g}' for x in v)}]")
        elif isinstance(v, dict):
            parts.append(f"{k} = {{{', '.join(f'{a}: {b:.3g}' for a, b in v.items())}}}")
        else:
            parts.append(f"{k} = {v}")
    return ", ".join(parts)
