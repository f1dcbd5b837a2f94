"""The diagnosed model put to use: predict drift with α *and* the effect a diagnosis
identified, and export it as a compensation law a robot controller or a CMM program applies.

A diagnosis (``thermrs diagnose --json``, SPEC §7) names an effect with its parameters and the
α fitted together with it (its ``ranking`` row), and promises a held-out shrink: 1 − RMS with
the effect / RMS of the nominal model. :func:`load_diagnosis` reads that into a
:class:`DiagnosedModel`; :func:`predict_series` predicts every visit of run tables with the
nominal model and with the diagnosed one (the same evaluation the diagnoser uses,
:class:`thermrs.signatures.VisitSet`, so a lag or a chip effect acts on the time axis of the
run), and :func:`shrink_table` compares both with the measurement per run and camera (each
(run, camera, axis) series' mean removed: a mounting offset is unknown, SPEC §4).

The compensation law (:func:`compensation_law`)
    Per camera pose and chip axis, the drift as a linear function of the measured
    temperatures: ``drift = Σ_T c_T · (T − reference_c)`` (µm), the coefficients being the
    forward model's slopes with the diagnosed α and geometric effects (secants over
    ``reference_c … reference_c + span_k``; :attr:`CompensationLaw.linearity_um` is the largest
    departure of the full model from the line over that span), a ``fixture_drift`` as its own
    ambient slope, a ``sensor_drift`` as an amplitude with its time constant and a
    ``thermal_lag`` as the time constant by which the structure lags the measured surface and
    the share of the expansion that lags (a controller filters the temperatures with it
    first and uses T + share·(T_s − T)). Each coefficient carries a 95 %
    interval: α's interval from the joint fit of α with the effects (the diagnosis'
    ``verdict.alpha_ci95``) and the effect parameters' (``params_ci95``: amplitudes from the
    joint fit's covariance, time constants by profile likelihood) propagated through the
    slope, and in quadrature the rig's stated tolerances: a ROI's reading (``ir_gain``, its
    emissivity) and the geometry's (each length, angle, chip and laser tolerance moving the
    slope); ``residual_um`` is the held-out RMS left after the effect (the
    diagnosis' ``how_far``), the uncertainty of one compensated pose.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from thermrs.effects import Effect, IrGain, from_dict, is_instrument
from thermrs.errors import InputError
from thermrs.identity import check_rig, rig_identity
from thermrs.model import ForwardModel
from thermrs.rig import Rig, as_rig, geometry_variants

__all__ = [
    "CompensationLaw",
    "DiagnosedModel",
    "compensation_law",
    "diagnosed_model",
    "load_diagnosis",
    "predict_series",
    "shrink_table",
]

#: Effects that act on the chip or the time axis, not on the geometry at one instant.
_TIME_EFFECTS = (
    "thermal_lag",
    "sensor_drift",
    "fixture_drift",
    "ir_drift",
    "ir_clock",
    "ir_noise",
)


@dataclass(frozen=True)
class DiagnosedModel:
    """What a diagnosis says to predict with (see :func:`load_diagnosis`)."""

    status: str
    nominal_alpha_per_k: float
    nominal_alpha_ci95: tuple[float, float]
    alpha_per_k: float
    effects: tuple[Effect, ...]
    params_ci95: dict[str, Any] = field(default_factory=dict)
    promised_shrink: float | None = None
    holdout_rms_before_um: float | None = None
    holdout_rms_after_um: float | None = None
    holdout_rms_after_ci95: tuple[float, float] | None = None
    note: str = ""
    #: α's 95 % interval from the fit of α together with the effects (the diagnosis'
    #: ``verdict.alpha_ci95``); None in a diagnosis written before it carried one.
    joint_alpha_ci95: tuple[float, float] | None = None
    #: The identity of the rig the diagnosis was made with (its ``rig``; empty in a
    #: diagnosis written before it carried one).
    rig: dict[str, Any] = field(default_factory=dict)
    #: The effect's other choices the data cannot tell from it (another joint, temperature,
    #: length or camera), each as fitted in its place (the diagnosis'
    #: ``verdict.params_alternatives_fitted``): the law's intervals span their laws.
    alternatives: tuple[DiagnosedModel, ...] = ()

    @property
    def alpha_ci95(self) -> tuple[float, float]:
        """α's 95 % interval: the joint fit's (α with the effects, :attr:`joint_alpha_ci95`);
        for a diagnosis without one, the nominal fit's relative interval around the diagnosed
        α (which a misspecified nominal model makes wide)."""
        if self.joint_alpha_ci95 is not None and all(np.isfinite(self.joint_alpha_ci95)):
            return self.joint_alpha_ci95
        lo, hi = self.nominal_alpha_ci95
        a0 = self.nominal_alpha_per_k
        if not (np.isfinite(lo) and np.isfinite(hi)) or a0 == 0:
            return (float("nan"), float("nan"))
        return (self.alpha_per_k * lo / a0, self.alpha_per_k * hi / a0)

    @property
    def alpha_ci95_spanning(self) -> tuple[float, float]:
        """α's 95 % interval widened to span each alternative's (:attr:`alternatives`: the
        choices the data cannot tell from the effect named, each fitted with its own α), as
        the law's slopes are; :attr:`alpha_ci95` without alternatives."""
        ends = [self.alpha_ci95, *(a.alpha_ci95 for a in self.alternatives)]
        lo = [e[0] for e in ends if np.isfinite(e[0])]
        hi = [e[1] for e in ends if np.isfinite(e[1])]
        if not lo or not hi:
            return self.alpha_ci95
        return (float(min(lo)), float(max(hi)))


def load_diagnosis(path: str | os.PathLike[str], rig: Rig | None = None) -> DiagnosedModel:
    """Read a ``thermrs diagnose --json`` document into the model it identified.

    ``identified`` and ``ambiguous`` verdicts give the verdict's effect with the α fitted
    together with it (its ``ranking`` row); ``none`` and ``unexplained`` give the nominal
    model (no effect), said in :attr:`DiagnosedModel.note`.

    Raises
    ------
    InputError
        No such file, not JSON, not a diagnosis (the missing key named), or an effect that
        does not fit the rig.
    """
    p = Path(path)
    what = f"--diagnosis {p}"
    try:
        doc = json.loads(p.read_text())
    except FileNotFoundError:
        raise InputError(f"{what}: no such file") from None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise InputError(f"{what}: not a `thermrs diagnose --json` file ({e})") from None
    return diagnosed_model(doc, rig, what=what)


def diagnosed_model(
    doc: Any, rig: Rig | None = None, *, what: str = "the diagnosis"
) -> DiagnosedModel:
    """The model a diagnosis document (``Diagnosis.to_json()``) identified; see
    :func:`load_diagnosis`."""
    if not isinstance(doc, dict):
        raise InputError(f"{what}: not a `thermrs diagnose --json` document")
    try:
        verdict = doc["verdict"]
        status = str(verdict["status"])
        base = doc["baseline"]["alpha_per_k"]
        a0 = float(base["value"])
        ci = tuple(float(x) for x in base.get("ci95", [np.nan, np.nan]))
        how = doc.get("how_far", {})
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"{what}: not a `thermrs diagnose --json` file (no {e})") from None
    made_with = doc.get("rig") if isinstance(doc.get("rig"), dict) else None
    if rig is not None:  # a diagnosis of another rig's cameras or ROIs is not this rig's
        res = doc.get("residuals")
        cams = (res.get("camera") or []) if isinstance(res, dict) else []
        check_rig(what, rig, made_with or None, cameras=set(map(str, cams)),
                  fix="give the rig it was made with")  # fmt: skip
    model = DiagnosedModel(
        status=status,
        rig=dict(made_with or {}),
        nominal_alpha_per_k=a0,
        nominal_alpha_ci95=(ci[0], ci[1]),
        alpha_per_k=a0,
        effects=(),
        holdout_rms_before_um=how.get("holdout_rms_before_um"),
    )
    name = verdict.get("effect")
    if status not in ("identified", "ambiguous") or not name:
        return replace(
            model,
            promised_shrink=0.0,
            holdout_rms_after_um=how.get("holdout_rms_before_um"),
            note=f"the diagnosis is {status!r}: no effect to add, the nominal model is used",
        )
    params = dict(verdict.get("params", {}))
    effect = from_dict({"name": name, **params}, rig=rig)
    row = next(
        (
            r
            for r in doc.get("ranking", [])
            if r.get("effect") == name and r.get("params") == params
        ),
        None,
    )
    if row is None or not isinstance(row.get("alpha_per_k"), int | float):
        raise InputError(f"{what}: the verdict's effect {name} has no ranking row with its α")
    before, after = how.get("holdout_rms_before_um"), verdict.get("holdout_rms_um")
    shrink = 1.0 - after / before if before and after is not None else None
    note = ""
    if status == "ambiguous":
        rivals = ", ".join(verdict.get("confounded_with", []))
        note = f"ambiguous: {rivals} explain the held-out runs about as well as {name}"
    alts = [str(a) for a in verdict.get("params_alternatives") or []]
    if alts:
        note = (
            f"{note + '; ' if note else ''}the data cannot tell its parameters from "
            f"{' or '.join(alts)}: the law's intervals span the laws of those fitted in its "
            "place, which agree only for temperature patterns like those of the diagnosis' runs"
        )
    ci_after = how.get("holdout_rms_after_ci95")
    joint = verdict.get("alpha_ci95")
    joint_alpha = verdict.get("alpha_per_k")
    others: list[DiagnosedModel] = []
    for alt in verdict.get("params_alternatives_fitted") or []:
        # A choice the core cannot take as an effect (a fitted weight past its bound) gives
        # no law to span: said in the note.
        try:
            a_ci = alt.get("alpha_ci95")
            eff = from_dict({"name": name, **dict(alt["params"])}, rig=rig)
            others.append(
                replace(
                    model,
                    alpha_per_k=float(alt["alpha_per_k"]),
                    joint_alpha_ci95=None if not a_ci else (float(a_ci[0]), float(a_ci[1])),
                    effects=(eff,),
                    params_ci95=dict(alt.get("params_ci95") or {}),
                )
            )
        except (KeyError, TypeError, ValueError, InputError) as e:
            note += f"; {alt.get('family', 'an alternative')} gives no law ({e})"
    return replace(
        model,
        alternatives=tuple(others),
        holdout_rms_after_ci95=None if not ci_after else (float(ci_after[0]), float(ci_after[1])),
        alpha_per_k=float(
            joint_alpha if isinstance(joint_alpha, int | float) else row["alpha_per_k"]
        ),
        joint_alpha_ci95=None if not joint else (float(joint[0]), float(joint[1])),
        effects=(effect,),
        params_ci95=dict(verdict.get("params_ci95", {})),
        promised_shrink=shrink,
        holdout_rms_after_um=after,
        note=note,
    )


def predict_series(
    tables: Sequence[pl.DataFrame], rig: Rig | str | os.PathLike[str], model: DiagnosedModel
) -> pl.DataFrame:
    """Every visit's drift, measured, predicted by the nominal model (the diagnosis' baseline
    α) and by the diagnosed one (α and the effect), anchored at the camera's first visit of
    its run, both chip axes.

    Returns
    -------
    polars.DataFrame
        ``run``, ``camera``, ``visit``, ``t_ns``, then per axis ``a`` in (u, v):
        ``measured_a_um``, ``nominal_a_um``, ``diagnosed_a_um``.
    """
    from thermrs.signatures import VisitSet

    r = as_rig(rig)
    vs = VisitSet(list(tables), r)
    nominal = vs.positions(alpha_per_k=model.nominal_alpha_per_k)
    diagnosed = vs.positions(effects=list(model.effects), alpha_per_k=model.alpha_per_k)
    n = vs.n
    first = np.empty(n, dtype=np.int64)
    for g in vs.groups:
        first[g] = g[0]

    def anchored(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u, v = x[:n], x[n:]
        return u - u[first], v - v[first]

    mu, mv = anchored(vs.y)
    nu, nv = anchored(nominal)
    du, dv = anchored(diagnosed)
    return vs.table.select("run", "camera", "visit", "t_ns").with_columns(
        measured_u_um=pl.Series(mu),
        measured_v_um=pl.Series(mv),
        nominal_u_um=pl.Series(nu),
        nominal_v_um=pl.Series(nv),
        diagnosed_u_um=pl.Series(du),
        diagnosed_v_um=pl.Series(dv),
    )


def shrink_table(series: pl.DataFrame) -> pl.DataFrame:
    """Per run and camera (and ``all``): the RMS of measured − predicted with each (run,
    camera, axis) series' mean removed, nominal and diagnosed, both axes, and the shrink
    1 − diagnosed / nominal."""
    rows = []
    keys = [*series.select("run", "camera").unique(maintain_order=True).iter_rows(), None]
    for key in keys:
        g = series if key is None else series.filter(
            (pl.col("run") == key[0]) & (pl.col("camera") == key[1])
        )  # fmt: skip
        res: dict[str, list[np.ndarray]] = {"nominal": [], "diagnosed": []}
        for (_, _), h in g.group_by(["run", "camera"], maintain_order=True):
            for a in "uv":
                m = h[f"measured_{a}_um"].to_numpy()
                for k in res:
                    d = m - h[f"{k}_{a}_um"].to_numpy()
                    d = d[np.isfinite(d)]
                    res[k].append(d - d.mean())
        rms = {k: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for k, v in res.items()}
        rows.append(
            {
                "run": "all" if key is None else key[0],
                "camera": "all" if key is None else key[1],
                "nominal_rms_um": rms["nominal"],
                "diagnosed_rms_um": rms["diagnosed"],
                "shrink": 1.0 - rms["diagnosed"] / rms["nominal"] if rms["nominal"] > 0 else 0.0,
                "n_visits": g.height,
            }
        )
    return pl.DataFrame(rows)


@dataclass(frozen=True)
class CompensationLaw:
    """The compensation law (see the module docstring): one row per camera, axis and term."""

    table: pl.DataFrame
    reference_c: float
    span_k: float
    linearity_um: float
    residual_um: float | None
    model: DiagnosedModel
    #: The identity of the rig the law is for (:func:`thermrs.identity.rig_identity`).
    rig: dict[str, Any] = field(default_factory=dict)

    def wide(self) -> pl.DataFrame:
        """The law as one self-contained row per camera pose and chip axis (the CSV a
        controller reads): ``reference_c``, then per temperature name ``<T>_um_per_k`` with
        its ``_ci95_low``/``_ci95_high``, then the chip and time terms (``chip_mount_…``,
        ``chip_drift_um``/``chip_drift_tau_min``, ``structure_lag_tau_min`` and
        ``structure_lag_share``). Units are in the
        column names; drift (µm) = Σ ``<T>_um_per_k`` · (T − ``reference_c``) + chip terms."""
        rows: dict[tuple[str, str, str], dict[str, Any]] = {}
        for r in self.table.iter_rows(named=True):
            key = (r["camera"], r["pose"], r["axis"])
            row = rows.setdefault(
                key,
                {"camera": key[0], "pose": key[1], "axis": key[2], "reference_c": self.reference_c},
            )
            col = _wide_column(r)
            for suffix, v in (("", r["coefficient"]), ("_ci95_low", r["ci95_low"]),
                              ("_ci95_high", r["ci95_high"])):  # fmt: skip
                row[col + suffix] = v
        return pl.DataFrame(list(rows.values()))

    def check(self, tables: Sequence[pl.DataFrame], rig: Rig) -> dict[str, Any]:
        """The law on held-out runs: the rms of measured − compensated drift (both axes, each
        series' mean removed) against the nominal model's, per run and over them all, and
        whether the rms over them all lies in the range the diagnosis promised for its own
        held-out runs taken together (:attr:`DiagnosedModel.holdout_rms_after_ci95`)."""
        series = predict_series(tables, rig, self.model)

        def row(name: str, part: pl.DataFrame) -> dict[str, Any]:
            (r,) = shrink_table(part).filter(pl.col("run") == "all").to_dicts()
            return {
                "run": name,
                "nominal_rms_um": r["nominal_rms_um"],
                "compensated_rms_um": r["diagnosed_rms_um"],
            }

        runs = series["run"].unique(maintain_order=True).to_list()
        every = row("all", series)
        ci = self.model.holdout_rms_after_ci95
        every["promised_ci95"] = None if ci is None else list(ci)
        every["inside"] = (
            None if ci is None else bool(ci[0] <= every["compensated_rms_um"] <= ci[1])
        )
        return {
            "runs": [row(str(r), series.filter(pl.col("run") == r)) for r in runs],
            "all": every,
        }

    def to_json(self) -> dict[str, Any]:
        """The document ``thermrs compensate -o comp.json`` writes."""
        m = self.model
        return {
            "law": "drift_um = sum over temperature terms of coefficient * (T - reference_c); "
            "chip terms as stated per row",
            "reference_c": self.reference_c,
            "span_k": self.span_k,
            "linearity_um": self.linearity_um,
            "residual_um": self.residual_um,
            "residual_ci95": None
            if m.holdout_rms_after_ci95 is None
            else list(m.holdout_rms_after_ci95),
            "residual_note": "the held-out rms a compensated run like the diagnosis' held-out "
            "runs keeps, and the range 95 % of such runs fall in",
            "alpha_per_k": m.alpha_per_k,
            # Spanning the alternatives' α as the slopes span their laws.
            "alpha_ci95": list(m.alpha_ci95_spanning),
            "effects": [e.to_dict() for e in m.effects],
            "diagnosis": {
                "status": m.status,
                "promised_shrink": m.promised_shrink,
                "holdout_rms_before_um": m.holdout_rms_before_um,
                "holdout_rms_after_um": m.holdout_rms_after_um,
                "note": m.note,
            },
            "terms": self.table.to_dicts(),
            # The rig the law is for: its poses, cameras and ROIs (and its digest).
            "rig": self.rig,
        }


def _wide_column(r: dict[str, Any]) -> str:
    """The wide table's column of a law row (:meth:`CompensationLaw.wide`)."""
    term = str(r["term"])
    if term.endswith("(T - reference_c)"):
        return f"{term.split(' ')[0]}_um_per_k"
    if term.startswith("ambient (T - reference_c), chip mount"):
        return "chip_mount_ambient_um_per_k"
    if term.startswith("chip self-drift"):
        return "chip_drift_um"
    if term.startswith("structure lag"):
        return "structure_lag_tau_min"
    if term.startswith("lagging share"):
        return "structure_lag_share"
    if " reading drift " in term:
        return f"{term.split(' ')[0]}_reading_drift_k_per_h"
    if term.startswith("thermal camera stamps late"):
        return "ir_clock_late_s"
    if term.startswith("smooth every T"):
        return "reading_smoothing_half_width_min"
    if term.startswith("smoothed share"):
        return "reading_smoothing_share"
    return term


def _spot(model: ForwardModel, rig: Rig, cam: str, temps: dict[str, np.ndarray]) -> np.ndarray:
    s = model.spots(cam, rig.camera_pose(cam).joints_rad, temperatures=temps)
    return np.stack([s.u_um, s.v_um])


def _slopes(
    rig: Rig, alpha: float, effects: Sequence[Effect], ref: float, steps: np.ndarray
) -> tuple[dict[tuple[str, str], np.ndarray], float]:
    """Per (camera, temperature): the secant slope (u, v) in µm/K over ``steps`` above
    ``ref``, the others held at ``ref``; and the largest departure from the secant (µm)."""
    fm = ForwardModel(rig, alpha_per_k=alpha, effects=list(effects))
    names = fm.temperature_names
    out: dict[tuple[str, str], np.ndarray] = {}
    worst = 0.0
    for cam in rig.cameras:
        at_ref = _spot(fm, rig, cam.name, {n: np.full(1, ref) for n in names})[:, 0]
        for name in names:
            temps = {n: np.full(len(steps), ref) for n in names}
            temps[name] = ref + steps
            path = _spot(fm, rig, cam.name, temps) - at_ref[:, None]
            slope = path[:, -1] / steps[-1]
            worst = max(worst, float(np.max(np.abs(path - slope[:, None] * steps[None, :]))))
            if np.any(slope != 0):
                out[(cam.name, name)] = slope
    return out, worst


def _geometry_sd(
    rig: Rig,
    alpha: float,
    effects: Sequence[Effect],
    ref: float,
    steps: np.ndarray,
    slopes: dict[tuple[str, str], np.ndarray],
) -> dict[tuple[str, str], np.ndarray]:
    """Per (camera, temperature): the standard uncertainty (u, v, µm/K) of the slope from the
    rig's stated geometric tolerances: the slope again on the rig with each DH length, twist,
    joint zero, chip and laser quantity moved by its standard uncertainty
    (:func:`thermrs.rig.geometry_variants`, the null world's own), the moves
    added in quadrature. A slope near zero is set by the geometry, not by α."""
    acc = {key: np.zeros(2) for key in slopes}
    for name, data in geometry_variants(rig):
        try:
            moved = Rig.from_dict(data, source_name=f"{rig.source} ({name})")
            got = _slopes(moved, alpha, effects, ref, steps)[0]
        except Exception:  # a variant the forward model cannot follow (the ray leaves a chip)
            continue
        for key, s0 in slopes.items():
            d = got.get(key, np.zeros(2)) - s0
            if np.all(np.isfinite(d)):
                acc[key] += d**2
    return {key: np.sqrt(v) for key, v in acc.items()}


def _param_corners(effects: Sequence[Effect], ci: dict[str, Any]) -> list[list[Effect]]:
    """The effects with each parameter that has an interval at its two ends: a scalar's, and
    each entry of a per-temperature one (``alpha_per_link``'s α of each temperature, whose
    interval comes from the joint fit's covariance with the common α)."""
    variants: list[list[Effect]] = [list(effects)]

    def at(e: Effect, key: str, entry: str | None, x: float) -> Effect:
        if entry is None:
            return replace(e, **{key: x})
        value = dict(getattr(e, key))
        value[entry] = x
        return replace(e, **{key: value})

    def ends(v: list[Effect], i: int, key: str, entry: str | None, c: Any) -> list[list[Effect]]:
        out = []
        centre = getattr(v[i], key) if entry is None else getattr(v[i], key)[entry]
        for end in c:
            # An end the effect cannot take (past a physical bound: a weight ≤ 0, |κ| > 0.1)
            # is moved towards the estimate until it can: the interval cut to the
            # parameter's space.
            good, bad = float(centre), float(end)
            try:
                new = at(v[i], key, entry, bad).check()
            except InputError:
                for _ in range(40):  # bisection to the bound
                    mid = (good + bad) / 2.0
                    try:
                        at(v[i], key, entry, mid).check()
                        good = mid
                    except InputError:
                        bad = mid
                new = at(v[i], key, entry, good)
            out.append([*v[:i], new, *v[i + 1 :]])
        return out

    for i, e in enumerate(effects):
        names = {f.name for f in fields(e)}
        for key, c in ci.items():
            if key not in names:
                continue
            value = getattr(e, key)
            if isinstance(value, int | float) and len(c) == 2:
                variants = [w for v in variants for w in ends(v, i, key, None, c)]
            elif isinstance(value, Mapping) and isinstance(c, dict):
                for entry, ce in c.items():
                    if entry in value and len(ce) == 2 and all(np.isfinite(ce)):
                        variants = [w for v in variants for w in ends(v, i, key, entry, ce)]
    return variants


def compensation_law(
    rig: Rig | str | os.PathLike[str], model: DiagnosedModel, *, span_k: float = 20.0
) -> CompensationLaw:
    """The compensation law of a diagnosed model on ``rig`` (see the module docstring).

    Parameters
    ----------
    rig
        The rig (its cameras' taught poses, its reference temperature).
    model
        The diagnosed model (:func:`load_diagnosis`).
    span_k
        The temperature rise above ``reference_c`` over which the slopes are secants and
        the linearity is checked.

    Returns
    -------
    CompensationLaw
        ``table``: ``camera``, ``pose``, ``axis``, ``term``, ``unit``, ``coefficient``,
        ``ci95_low``, ``ci95_high``.
    """
    r = as_rig(rig)
    if not span_k > 0:
        raise InputError(f"span_k must be > 0, got {span_k}")
    check_rig("the diagnosis", r, model.rig or None, fix="give the rig it was made with")
    if model.status == "ambiguous":
        # Confounded laws agree on the runs diagnosed and may disagree anywhere else: a
        # controller must not be handed one of them as the law.
        raise InputError(
            f"the diagnosis is ambiguous ({model.note}): its effects give different laws "
            "where these runs did not go; separate them first (thermrs design proposes the "
            "run that does) and compensate from a diagnosis that identifies one"
        )
    geometric = [
        e for e in model.effects if e.name not in _TIME_EFFECTS and not is_instrument(e.name)
    ]
    gains = {e.roi: e for e in model.effects if isinstance(e, IrGain)}
    ref = r.reference_c
    steps = np.linspace(0.0, span_k, 21)
    slopes, worst = _slopes(r, model.alpha_per_k, geometric, ref, steps)
    # The interval: the slopes at the corners of α's interval and each geometric effect's
    # scalar parameter's interval.
    corners = []
    for a in model.alpha_ci95:
        for variant in _param_corners(geometric, model.params_ci95):
            if np.isfinite(a):
                corners.append(_slopes(r, a, variant, ref, steps)[0])
    rows: list[dict[str, Any]] = []
    # A coefficient per *measured* kelvin of one ROI is as uncertain as that ROI's reading:
    # its own gain (emissivity) is known to the rig's stated `ir_gain`, which no fit of one α
    # can see. Added in quadrature to the fit's interval.
    roi_gain = float(r.tolerances.get("ir_gain", 0.0))
    geometry_sd = _geometry_sd(r, model.alpha_per_k, geometric, ref, steps, slopes)
    for (cam, name), slope in slopes.items():
        pose = r.camera(cam).pose
        for k, axis in enumerate("uv"):
            ends = [c[(cam, name)][k] for c in corners]
            lo, hi = (min(ends), max(ends)) if ends else (float("nan"), float("nan"))
            if name in gains:
                # The ROI reads its rise (1 + g) too large: per measured kelvin the slope is
                # 1/(1 + g) of the structure's, and as uncertain as g is.
                g = gains[name].gain
                g_ci = model.params_ci95.get("gain") or [g, g]
                slope = slope / (1.0 + g)
                lo, hi = lo / (1.0 + g), hi / (1.0 + g)
                rel = (float(g_ci[1]) - float(g_ci[0])) / 2.0 / (1.0 + g)
                extra_g = rel * abs(float(slope[k]))
                lo = float(slope[k]) - float(np.hypot(float(slope[k]) - lo, extra_g))
                hi = float(slope[k]) + float(np.hypot(hi - float(slope[k]), extra_g))
            if np.isfinite(lo) and np.isfinite(hi):
                gain = roi_gain if name != "ambient" and name not in gains else 0.0
                extra = 1.96 * float(np.hypot(gain * float(slope[k]), geometry_sd[(cam, name)][k]))
                lo = float(slope[k]) - float(np.hypot(float(slope[k]) - lo, extra))
                hi = float(slope[k]) + float(np.hypot(hi - float(slope[k]), extra))
            rows.append(
                {"camera": cam, "pose": pose, "axis": axis,
                 "term": f"{name} (T - reference_c)", "unit": "um/K",
                 "coefficient": float(slope[k]), "ci95_low": lo, "ci95_high": hi}
            )  # fmt: skip
    for c in r.cameras:
        for e in model.effects:
            rows += _chip_rows(e, c.name, c.pose, model.params_ci95)
    if model.alternatives:
        rows = _spanning(rows, [compensation_law(r, a, span_k=span_k) for a in model.alternatives])
    table = pl.DataFrame(rows).filter(
        (pl.col("coefficient") != 0)
        | (pl.col("ci95_low") != pl.col("ci95_high"))
        | ~pl.col("term").str.contains("reference_c")
    )
    return CompensationLaw(
        table=table,
        reference_c=ref,
        span_k=span_k,
        linearity_um=worst,
        residual_um=model.holdout_rms_after_um,
        model=model,
        rig=rig_identity(r),
    )


def _spanning(rows: list[dict[str, Any]], others: list[CompensationLaw]) -> list[dict[str, Any]]:
    """The slopes per kelvin of ``rows`` with each interval widened to span the same slope's
    interval in the ``others`` (the laws of the choices the data cannot tell from the one
    named); a slope only another law has is 0 here, its interval spanning 0 and theirs."""
    key = ("camera", "axis", "term")
    out = {tuple(x[k] for k in key): dict(x) for x in rows}
    for law in others:
        for o in law.table.iter_rows(named=True):
            if not str(o["term"]).endswith("(T - reference_c)"):
                continue
            k = tuple(o[q] for q in key)
            if k not in out:
                out[k] = {**o, "coefficient": 0.0, "ci95_low": 0.0, "ci95_high": 0.0}
            x = out[k]
            x["ci95_low"] = float(np.nanmin([x["ci95_low"], o["ci95_low"]]))
            x["ci95_high"] = float(np.nanmax([x["ci95_high"], o["ci95_high"]]))
    return list(out.values())


def _chip_rows(e: Effect, cam: str, pose: str, ci: dict[str, Any]) -> list[dict[str, Any]]:
    """Rows of the effects that act on the chip or the time axis."""
    d = e.to_dict()
    rows: list[dict[str, Any]] = []

    def row(axis: str, term: str, unit: str, v: float, lo: float, hi: float) -> None:
        rows.append(
            {"camera": cam, "pose": pose, "axis": axis, "term": term, "unit": unit,
             "coefficient": float(v), "ci95_low": float(lo), "ci95_high": float(hi)}
        )  # fmt: skip

    def interval(key: str, k: int | None, v: float) -> tuple[float, float]:
        c = ci.get(key)
        if c is None:
            return (float("nan"), float("nan"))
        c = c[k] if k is not None else c
        return (float(c[0]), float(c[1]))

    if e.name == "thermal_lag":
        w = float(d.get("weight", 1.0))
        for axis in "uv":
            row(axis, "structure lag (filter every T first: dT_s/dt = (T - T_s)/tau)", "min",
                d["tau_min"], *interval("tau_min", None, d["tau_min"]))  # fmt: skip
            row(axis, "lagging share (use T + share * (T_s - T) for every T)", "1", w,
                *interval("weight", None, w))  # fmt: skip
    elif e.name == "fixture_drift" and d["camera"] == cam:
        tau = float(d.get("mount_tau_min", 0.0))
        mount = f" (filter ambient first: dT_m/dt = (T - T_m)/{tau:.4g} min)" if tau > 0 else ""
        for k, axis in enumerate("uv"):
            v = d["um_per_k"][k]
            row(axis, f"ambient (T - reference_c), chip mount{mount}", "um/K", v,
                *interval("um_per_k", k, v))  # fmt: skip
            if tau > 0:
                row(axis, "chip mount lag", "min", tau, *interval("mount_tau_min", None, tau))
    elif e.name == "ir_drift":
        for axis in "uv":
            row(axis, f"{d['roi']} reading drift (subtract from T: k * t_run_h)", "K/h",
                d["k_per_h"], *interval("k_per_h", None, d["k_per_h"]))  # fmt: skip
    elif e.name == "ir_clock":
        for axis in "uv":
            row(axis, "thermal camera stamps late (read every T at t + s)", "s",
                d["s"], *interval("s", None, d["s"]))  # fmt: skip
    elif e.name == "ir_noise":
        hw, w = float(d["half_width_min"]), float(d.get("weight", 1.0))
        for axis in "uv":
            row(axis, "smooth every T first (local quadratic over ± half-width, per run)", "min",
                hw, *interval("half_width_min", None, hw))  # fmt: skip
            row(axis, "smoothed share (use T + share * (T_smooth - T) for every T)", "1", w,
                *interval("weight", None, w))  # fmt: skip
    elif e.name == "sensor_drift" and d["camera"] == cam:
        for k, axis in enumerate("uv"):
            v = d["um"][k]
            row(axis, f"chip self-drift um * (1 - exp(-t_run / {d['tau_min']:.4g} min))", "um",
                v, *interval("um", k, v))  # fmt: skip
    return rows
