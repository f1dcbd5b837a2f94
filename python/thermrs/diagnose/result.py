"""The diagnosis as a document: the :class:`Diagnosis` record and its assembly from the
steps' results (ranking rows, tests, verdict, how far, the residual table)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.diagnose.candidates import Candidate
from thermrs.diagnose.family_fit import Fit
from thermrs.diagnose.floor import NoiseFloor
from thermrs.diagnose.selection import Step
from thermrs.diagnose.verdict import english_list, summary
from thermrs.effects import is_instrument
from thermrs.signatures import VisitSet

__all__ = ["Diagnosis", "assemble"]

FloatArray = npt.NDArray[np.float64]


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
    noise_floor: dict[str, Any] = field(default_factory=dict)
    tests: dict[str, Any] = field(default_factory=dict)
    #: Per run, the digest of its table's content (:func:`thermrs.identity.run_digests`);
    #: empty in a diagnosis written before it was recorded.
    run_digests: dict[str, str] = field(default_factory=dict)
    #: The identity of the rig it was made with (:func:`thermrs.identity.rig_identity`).
    rig: dict[str, Any] = field(default_factory=dict)

    @property
    def status(self) -> str:
        """The verdict (SPEC §7): ``identified``, ``ambiguous``, ``unexplained`` (a partial
        explanation included: see :attr:`outcome`) or ``none``."""
        return str(self.verdict["status"])

    @property
    def outcome(self) -> str:
        """:attr:`status`, with a partial explanation told apart: ``partially explained``
        where effects were found but what they leave is still a gap."""
        return str(self.verdict.get("outcome", self.verdict["status"]))

    def to_json(self) -> dict[str, Any]:
        """The SPEC §7 ``thermrs diagnose --json`` document (extended)."""
        return {
            "noise_floor_um": self.noise_floor_um,
            "noise_floor": self.noise_floor,
            "baseline": self.baseline,
            "location": self.location,
            "drivers": self.drivers,
            "whiteness": self.whiteness,
            "ranking": self.ranking,
            "confounded": self.confounded,
            "selected": self.selected,
            "tests": self.tests,
            "verdict": self.verdict,
            "how_far": self.how_far,
            "library": self.library,
            "excluded": self.excluded,
            "summary": self.summary,
            # Every visit's held-out and training residual, nominal and with the model, by
            # column: what `thermrs report --diagnosis` draws without diagnosing again.
            "residuals": {c: self.residuals[c].to_list() for c in self.residuals.columns},
            # What it belongs to: its runs' content and its rig (refused for other ones).
            "run_digests": self.run_digests,
            "rig": self.rig,
        }

    @classmethod
    def from_json(cls, doc: Mapping[str, Any], *, source: str = "the diagnosis") -> Diagnosis:
        """The diagnosis from its :meth:`to_json` document (a ``thermrs diagnose --json``
        file), to pass on to the report, ``design`` and ``compensate`` instead of diagnosing
        the same runs again.

        Raises
        ------
        InputError
            ``doc`` is not a diagnosis document (``source`` names it in the message).
        """
        from thermrs.errors import InputError

        need = ("noise_floor_um", "baseline", "location", "ranking", "verdict", "how_far")
        missing = [k for k in need if k not in doc] if isinstance(doc, Mapping) else list(need)
        if missing:
            raise InputError(
                f"{source}: not a `thermrs diagnose --json` document (no {', '.join(missing)})"
            )
        res = doc.get("residuals") or {}
        try:
            residuals = pl.DataFrame(res) if res else pl.DataFrame()
        except (TypeError, ValueError, pl.exceptions.PolarsError) as e:
            raise InputError(f"{source}: its residuals are not a table ({e})") from None
        return cls(
            noise_floor_um=float(doc["noise_floor_um"]),
            baseline=dict(doc["baseline"]),
            location=list(doc["location"]),
            drivers=list(doc.get("drivers", [])),
            whiteness=dict(doc.get("whiteness", {})),
            ranking=list(doc["ranking"]),
            confounded=list(doc.get("confounded", [])),
            verdict=dict(doc["verdict"]),
            how_far=dict(doc["how_far"]),
            selected=list(doc.get("selected", [])),
            library=list(doc.get("library", [])),
            excluded=list(doc.get("excluded", [])),
            summary=str(doc.get("summary", "")),
            residuals=residuals,
            noise_floor=dict(doc.get("noise_floor", {})),
            tests=dict(doc.get("tests", {})),
            run_digests={str(k): str(v) for k, v in (doc.get("run_digests") or {}).items()},
            rig=dict(doc.get("rig") or {}),
        )

    @classmethod
    def read(cls, path: str | Path) -> Diagnosis:
        """:meth:`from_json` of a ``thermrs diagnose --json`` file.

        Raises
        ------
        InputError
            The file is missing, not JSON, or not a diagnosis.
        """
        import json

        from thermrs.errors import InputError

        p = Path(path)
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"{p}: no such file") from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise InputError(f"{p}: not a JSON file ({e})") from None
        return cls.from_json(doc, source=str(p))

    def runs(self) -> dict[str, list[str]]:
        """The runs it was made on: ``{"train": […], "holdout": […]}`` in their order."""
        out: dict[str, list[str]] = {"train": [], "holdout": []}
        for r in self.baseline.get("per_run", []):
            role = "train" if r.get("role") == "train" else "holdout"
            if r["run"] not in out[role]:
                out[role].append(str(r["run"]))
        return out

    @property
    def unverified(self) -> str | None:
        """Why its runs can be matched by name only (a diagnosis written before it carried
        a digest of its runs), else None."""
        if self.run_digests:
            return None
        return (
            "the diagnosis carries no digest of its runs (written by an older thermrs): its "
            "runs are matched by name only; diagnose them again to have them checked"
        )

    def check_runs(
        self,
        train: Sequence[str],
        holdout: Sequence[str],
        *,
        tables: Sequence[pl.DataFrame] = (),
        rig: Any = None,
    ) -> None:
        """Raise :class:`~thermrs.errors.InputError` unless it was made on exactly these
        training and held-out runs (a diagnosis of other runs cannot be passed on): their
        names, and, given their ``tables``, their content (the digest it carries of each,
        where it carries one); given the ``rig``, unless it was made with the same cameras
        and ROIs (:func:`thermrs.identity.check_rig`)."""
        from thermrs.errors import InputError
        from thermrs.identity import check_rig, run_digests

        mine = self.runs()
        for role, given in (("train", train), ("holdout", holdout)):
            if sorted(mine[role]) != sorted(str(g) for g in given):
                raise InputError(
                    f"the diagnosis was made with {role} runs {', '.join(mine[role]) or 'none'}, "
                    f"not {', '.join(map(str, given)) or 'none'}: diagnose these runs, or give "
                    "the runs it was made on"
                )
        if rig is not None:
            cams = self.residuals["camera"].unique().to_list() if "camera" in self.residuals else []
            check_rig("the diagnosis", rig, self.rig or None, cameras=cams,
                      fix="give the rig it was made with")  # fmt: skip
        if tables and self.run_digests:
            now = run_digests(tables)
            other = [n for n, d in now.items() if self.run_digests.get(n, d) != d]
            if other:
                raise InputError(
                    f"the diagnosis was made on other data under the same run names "
                    f"({', '.join(other)} differ from the runs it diagnosed): diagnose these "
                    "runs, or give the runs it was made on"
                )


def instrument_advice(name: str, params: Mapping[str, Any]) -> str:
    """What to check on the instrument an instrument effect names, in one clause."""
    p = {k: v for k, v in params.items()}
    said = {
        "ir_gain": lambda: (
            f"check the emissivity of {p['roi']}: its reading of the rise above "
            f"the room is {abs(p['gain']):.1%} {'high' if p['gain'] > 0 else 'low'}"
        ),
        "ir_drift": lambda: (
            f"check the thermal camera's offset on {p['roi']}: its reading "
            f"drifts {p['k_per_h']:+.2f} K per hour of the run"
        ),
        "ir_clock": lambda: (
            f"check the thermal camera's clock: its frames are stamped "
            f"{abs(p['s']):.0f} s {'late' if p['s'] > 0 else 'early'} against the CCD cameras'"
        ),
        "ir_noise": lambda: (
            "check the thermal camera's readings: they scatter from visit to visit by more "
            f"than the analysis' smoother takes out (smoothed over ±{p['half_width_min']:.0f} "
            "min they predict the spots better; noise_floor.thermometers gives each ROI's "
            "scatter)"
        ),
    }.get(name)
    return "" if said is None else said() + " — an instrument error, not the robot's"


def _ranking_row(c: Candidate, base_rms: float, n_eff_train: float) -> dict[str, Any]:
    f = c.fit
    ci = dict(c.ci)
    prof = f.extra.get("profile") or []
    if c.family.refine and prof and c.family.refine[0] not in ci:
        # Only where the profile-likelihood interval could not be computed: the grid points
        # the same criterion keeps.
        key = c.family.refine[0]
        best_rss = min(r for _, r in prof)
        lim = best_rss * (1.0 + 3.84 / max(n_eff_train, 1.0))
        ok = [e[key] for e, r in prof if r <= lim] + [f.eta[key]]
        ci[key] = [float(min(ok)), float(max(ok))]
    return {
        "effect": c.effect,
        "family": c.family.label,
        "params": c.params,
        "params_ci95": ci,
        "alpha_per_k": f.alpha,
        "train_rms_um": f.train_rms_um,
        "holdout_rms_um": f.holdout_rms_um,
        "holdout_max_um": f.holdout_max_um,
        "shrink": 1.0 - f.holdout_rms_um / base_rms if base_rms > 0 else 0.0,
        "evidence": {
            "gain_p": c.gain_p,
            "gain_z": c.gain_z,
            "gap_closed": c.closed,
            "gap_closed_raw": c.closed_raw,
            "delta_aicc": c.d_aicc,
            "n_eff": n_eff_train,
            "stability": c.stability,
            "placebo_holdout_rms_um": c.placebo_rms,
            "placebo_beaten": c.placebo_beaten,
            "plausible": c.plausible,
            "identifiable": c.identifiable,
            "qualifies": c.significant and c.plausible,
        },
    }


def _tests(steps: list[Step], level: float) -> dict[str, Any]:
    return {
        "level": level,
        "per_test_level": level / 4.0,
        "method": "parametric bootstrap of the whole pipeline in a world where the model of "
        "each step is the truth (its fit, the floor's noise model per series, and the rig "
        "drawn within its stated tolerances); Bonferroni over the four tests that `none` must "
        "pass, the first step's gains at the level itself where its other tests already "
        "show a gap (closed testing); p-values are (1 + k)/(B + 1), never below what the "
        "draws resolve",
        "steps": [
            {
                "model": [c.label for c in s.model],
                "holdout_rms_um": float(np.sqrt(s.hold_ms)),
                "null_holdout_rms_um_95": float(np.sqrt(np.quantile(s.null_hold_ms, 0.95)))
                if len(s.null_hold_ms)
                else None,
                "p_at_floor": s.p_at_floor,
                "p_white_at_thermal_scales": s.p_low,
                "p_best_gain": s.p_gain,
                "p_floor_contradicted": s.p_floor_contradicted,
                "gain_threshold_um2": s.threshold,
                "gain_level": s.gain_level,
                "significant": s.significant,
                "chosen": None if s.chosen is None else s.chosen.label,
                "chosen_by": None if s.chosen is None else s.chosen_by,
                "draws": s.draws,
                "rival_draws": s.rival_draws,
                "detectable_um": s.detectable_um,
                "rivals": s.rivals,
                "rival_p": s.rival_p,
                "outside_rivals": s.outside,
                "alternatives_p": s.alt_p,
                "alternatives_p_equal_accuracy": s.alt_p_accuracy,
                "alternatives": s.alternatives,
            }
            for s in steps
        ],
    }


def _rig_statement(
    status: str,
    reason: str,
    selected: list[dict[str, Any]],
    rivals: list[str],
    floor: NoiseFloor,
) -> tuple[str, str, bool, bool]:
    """The verdict with what the data say of the rig's errors against its statement:
    ``unexplained`` where the effects of the robot it would name are not significant against
    a rig erring by up to three times its stated tolerances (``tests.tolerance_excess``,
    :mod:`.guard`), and the factor
    the data give (``tests.tolerance_scale``) said where its interval lies above 1. Returns
    (status, reason, exceeded, errs_more)."""
    excess = floor.extra.get("tolerance_excess") or {}
    robot = [
        e
        for e in dict.fromkeys([*(sel["effect"] for sel in selected), *rivals])
        if not is_instrument(e)
    ]
    exceeded = bool(excess.get("explains")) and status != "none" and bool(robot)
    if exceeded:
        # The data do not tell the effects of the robot from a rig that errs by as much more
        # than it states as they allow: the rig's statement is what to check first.
        status = "unexplained"
        # No effect of the robot is offered, not even as what the gap might be: it is the
        # rig's statement that fails first (the effects tested are in the test's record).
        advice = [
            instrument_advice(sel["effect"], sel["params"])
            for sel in selected
            if is_instrument(sel["effect"])
        ]
        found = (
            f"; the thermal camera's error found with them stands: {'; '.join(advice)}"
            if advice
            else ""
        )
        p_robot = min((excess.get("p_by_effect") or {}).get(e, 1.0) for e in robot)
        reason = (
            f"what these runs show is within what the rig leaves by itself were its errors up "
            f"to {excess['scale']:.2g}× what it states (no effect of the robot stands out of "
            f"that, p {p_robot:.2f}): check the rig's tolerances (docs/tolerances.md) before "
            f"looking for an effect of the robot{found}"
        )
    scale_doc = floor.extra.get("tolerance_scale") or {}
    # What the verdict says of the rig: k on the residual of the model with the effects
    # selected, where there are any (the one the test used) and they are named; the nominal
    # residual's otherwise.
    with_effects = None if exceeded else scale_doc.get("with_effects")
    said_scale = with_effects or scale_doc
    errs_more = bool(said_scale.get("exceeds_stated"))
    if errs_more:
        lo, hi = said_scale["ci95"]
        size = (
            f"{said_scale['estimate']:.2g}× what it states ({lo:.2g}–{hi:.2g}× at 95 %"
            f"{'' if said_scale['upper_bounded'] else ' or more'})"
        )
        if with_effects:
            names = english_list([s["effect"] for s in selected])
            reason += (
                f"; once {names} {'is' if len(selected) == 1 else 'are'} fitted, what is left "
                f"along the rig's tolerances' signatures is {size}: the rig errs by more than "
                f"it states, or {names} fit{'s' if len(selected) == 1 else ''} the data only "
                "in part; check its tolerances (docs/tolerances.md)"
            )
        elif exceeded:
            reason = reason.replace(
                "): check the rig's tolerances",
                f"), and they look {size} from the residual along its tolerances' "
                "signatures: check its tolerances",
            )
        else:
            reason += (
                f"; the rig's errors look {size}, from the residual along its tolerances' "
                "signatures: check its tolerances (docs/tolerances.md)"
            )
    return status, reason, exceeded, errs_more


def _closing(how_far: dict[str, Any], base: Fit, floor: NoiseFloor, final: Fit | None) -> None:
    """The gap above the floor and the share of it closed, with its 95 % interval (before,
    after and the floor uncertain together: :mod:`.closing`), into ``how_far``."""
    fl = floor.holdout_um
    fci = floor.holdout_ci95
    before_rms = base.holdout_rms_um
    how_far["gap_above_floor_um"] = before_rms - fl
    how_far["gap_above_floor_ci95"] = [before_rms - fci[1], before_rms - fci[0]] if fci else None
    closing = floor.extra.get("closing") if final is not None else None
    ci = None if closing is None else closing.get("ci95")
    how_far["gap_closed_ci95"] = (
        None if ci is None else [max(min(ci[0], 1.0), 0.0), max(min(ci[1], 1.0), 0.0)]
    )
    how_far["gap_closed_raw_ci95"] = ci
    how_far["gap_closed_interval"] = closing


def _how_far(base: Fit, after: Fit, fl: float, changed: bool) -> dict[str, Any]:
    base_rms = base.holdout_rms_um
    gap = base_rms - fl
    raw = (base_rms - after.holdout_rms_um) / gap if gap > 0 and changed else None
    return {
        "holdout_rms_before_um": base_rms,
        "holdout_rms_after_um": after.holdout_rms_um,
        "holdout_max_before_um": base.holdout_max_um,
        "holdout_max_after_um": after.holdout_max_um,
        "noise_floor_um": fl,
        "gap_closed": None if raw is None else min(raw, 1.0),
        "gap_closed_raw": raw,
        "gap_closed_note": (
            "the effects remove more than the gap above the floor: the floor is an estimate "
            "and reads high here"
            if raw is not None and raw > 1.0
            else None
        ),
    }


def _residual_table(
    vs: VisitSet,
    base: Fit,
    final: Fit | None,
    phase: npt.NDArray[np.str_],
    role_visit: npt.NDArray[np.str_],
) -> pl.DataFrame:
    t_h = (np.concatenate([vs.t_since_start, vs.t_since_start])) / 3600.0
    return pl.DataFrame(
        {
            "run": np.concatenate([vs.run, vs.run]),
            "role": np.concatenate([role_visit, role_visit]),
            "camera": np.concatenate([vs.camera, vs.camera]),
            "axis": vs.axis,
            "t_ns": np.concatenate([vs.table["t_ns"].to_numpy()] * 2),
            "t_h": t_h,
            "phase": np.concatenate([phase, phase]),
            "baseline_um": base.residual,
            "after_um": final.residual if final is not None else np.full(2 * vs.n, np.nan),
        }
    ).with_columns(pl.col("after_um").fill_nan(None))


def assemble(
    *,
    vs: VisitSet,
    base: Fit,
    floor: NoiseFloor,
    final: Fit | None,
    selected: list[dict[str, Any]],
    steps: list[Step],
    cands: list[Candidate],
    verdict: tuple[str, str, list[str]],
    level: float,
    where: dict[str, Any],
    role_visit: npt.NDArray[np.str_],
    library: tuple[list[str], list[str]],
    n_eff_train: float,
    margin_um: float = 0.0,
    tolerances: tuple[dict[str, float], list[str], bool] = ({}, [], True),
) -> Diagnosis:
    """The :class:`Diagnosis` from the steps' results."""
    status, reason, rivals = verdict
    classes, exclude = library
    phase = where["phase"]
    base_rms = base.holdout_rms_um
    fl = floor.holdout_um
    ranking = [_ranking_row(c, base_rms, n_eff_train) for c in cands]
    after = final if final is not None else base
    how_far = _how_far_spread(base, after, floor, final is not None, steps)
    _closing(how_far, base, floor, final)
    status, reason, exceeded, errs_more = _advised(status, reason, selected, rivals, ranking, floor)
    verdict_doc = _verdict_doc(status, reason, exceeded, errs_more, selected, rivals, steps, after)
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
    residuals = _residual_table(vs, base, final, phase, role_visit)
    d = Diagnosis(
        noise_floor_um=fl,
        baseline=baseline,
        location=where["loc"],
        drivers=where["drv"][:20],
        whiteness=where["white"],
        ranking=ranking,
        confounded=where["confounded"],
        verdict=verdict_doc,
        how_far=how_far,
        selected=[
            {
                k: s[k]
                for k in (
                    "effect",
                    "family",
                    "params",
                    "params_ci95",
                    "alpha_per_k",
                    "alpha_ci95",
                    "alternatives",
                )
                if k in s
            }
            for s in selected
        ],
        library=classes,
        excluded=exclude,
        summary="",
        residuals=residuals,
        noise_floor=floor.to_json(),
        tests=_tests_doc(steps, cands, level, margin_um, floor, tolerances),
    )
    d.summary = summary(d)
    return d


def _how_far_spread(
    base: Fit, after: Fit, floor: NoiseFloor, named: bool, steps: list[Step]
) -> dict[str, Any]:
    """How far the model gets (:func:`_how_far`), with the 95 % range of what held-out runs
    like these keep after it (``named``: an effect was); the gap and the share closed are
    :func:`_closing`'s."""
    how_far = _how_far(base, after, floor.holdout_um, named)
    # What held-out runs like these keep after the model: the rms the model left on them,
    # with the relative spread the held-out rms has from one set of runs to another (the
    # last step's null world, where the final model is the truth: the floor's noise, the
    # rig's tolerances, the model refitted).
    spread = steps[-1].null_hold_ms_profiled
    spread = spread if len(spread) else steps[-1].null_hold_ms
    last = np.sqrt(spread[np.isfinite(spread)])
    mid = float(np.median(last)) if len(last) else 0.0
    # The rms left here is itself one draw: a new set of runs differs from it by the
    # difference of two independent draws, √2 times one draw's spread.
    how_far["holdout_rms_after_ci95"] = (
        [
            after.holdout_rms_um * (1.0 + np.sqrt(2.0) * (float(np.quantile(last, q)) / mid - 1.0))
            for q in (0.025, 0.975)
        ]
        if len(last) >= 19 and mid > 0
        else None
    )
    how_far["holdout_rms_after_ci95_note"] = (
        "95 % of sets of held-out runs like these keep an rms in this range once the model "
        "is applied: the rms it left here, spread as the held-out rms spreads in the model's "
        "null world (the floor's noise, the rig's tolerances, the model refitted, its last "
        "effect's time constant or choice profiled again)"
    )
    return how_far


def _advised(
    status: str,
    reason: str,
    selected: list[dict[str, Any]],
    rivals: list[str],
    ranking: list[dict[str, Any]],
    floor: NoiseFloor,
) -> tuple[str, str, bool, bool]:
    """The verdict's status and reason with the instruments' advice and what the data say of
    the rig's errors (:func:`_rig_statement`: (status, reason, exceeded, errs_more))."""
    advice = [
        instrument_advice(sel["effect"], sel["params"])
        for sel in selected
        if is_instrument(sel["effect"])
    ]
    if status == "ambiguous":
        # An instrument among the confounded effects is the first thing to check: it costs an
        # afternoon with a contact probe, not a designed run of the robot.
        for name in rivals:
            row = next((r for r in ranking if r["effect"] == name), None)
            if is_instrument(name) and row is not None:
                advice.append(
                    "the thermal camera's error explains it as well — "
                    + instrument_advice(name, row["params"])
                    + "; check it before designing a run of the robot"
                )
    if advice and status != "none":
        reason = f"{reason}; {'; '.join(advice)}"
    return _rig_statement(status, reason, selected, rivals, floor)


def _verdict_doc(
    status: str,
    reason: str,
    exceeded: bool,
    errs_more: bool,
    selected: list[dict[str, Any]],
    rivals: list[str],
    steps: list[Step],
    after: Fit,
) -> dict[str, Any]:
    """The ``verdict`` of the document (SPEC §7)."""
    first = selected[0] if selected else None
    return {
        # SPEC §7's four statuses; a partial explanation is `unexplained` there (what is left
        # is still a gap) and says so in `outcome` and `partially_explained`.
        "status": "unexplained" if status == "partially explained" else status,
        "outcome": status,
        "partially_explained": status == "partially explained",
        # The gap is within what the rig leaves if it errs by up to three times its stated
        # tolerances (tests.tolerance_excess, .guard): no effect of the robot is named.
        "rig_tolerances_exceeded": exceeded,
        # The data show the rig's errors exceed what it states: the 95 % interval of the
        # factor (tests.tolerance_scale, on the residual of the model reported) lies above 1.
        "rig_errors_exceed_stated": errs_more,
        # The effect that explains the gap: none does where what is left is still a gap
        # ("partially explained": the effects that explain a part are in `effects`).
        "effect": None
        if first is None or status in ("unexplained", "partially explained")
        else first["effect"],
        # Where the rig's excess explains the gap, only the thermal camera's (no effect of
        # the robot is offered).
        "effects": [s["effect"] for s in selected if not exceeded or is_instrument(s["effect"])],
        # Those of them that are the thermal camera's errors, not the robot's.
        "instruments": [s["effect"] for s in selected if is_instrument(s["effect"])],
        # SPEC §7: no parameters without their effect (a partial explanation's are in
        # `selected`).
        "params": {} if first is None or status == "partially explained" else first["params"],
        "params_ci95": {}
        if first is None or status == "partially explained"
        else first["params_ci95"],
        # The effect's other discrete choices (joint, temperature, length, camera) the data
        # cannot reject as the truth: its family labels.
        "params_alternatives": []
        if first is None or status == "partially explained"
        else first.get("alternatives", []),
        # Each of them fitted jointly in the effect's place (family, params, params_ci95,
        # alpha_per_k, alpha_ci95): the compensation law's intervals span their laws.
        "params_alternatives_fitted": []
        if first is None or status == "partially explained"
        else first.get("alternative_fits", []),
        "confounded_with": rivals if status == "ambiguous" else [],
        # Excluded effects (never named) that explain the gap as well as the effects
        # selected and that the data cannot reject: those effects may only stand in for them.
        "stand_in_for": sorted({e for s in steps for e in s.outside}),
        # α fitted together with the effects named (the joint fit; its interval from the joint
        # fit's covariance), where the verdict names one: the α of the diagnosed model.
        "alpha_per_k": None if first is None else first.get("alpha_per_k"),
        "alpha_ci95": None if first is None else first.get("alpha_ci95"),
        "holdout_rms_um": after.holdout_rms_um,
        "reason": reason,
    }


def _tests_doc(
    steps: list[Step],
    cands: list[Candidate],
    level: float,
    margin_um: float,
    floor: NoiseFloor,
    tolerances: tuple[dict[str, float], list[str], bool],
) -> dict[str, Any]:
    """The ``tests`` of the document: the steps' tests, what was detectable, the tolerances."""
    return {
        **_tests(steps, level),
        "margin_um": margin_um,
        "detectable_um": steps[0].detectable_um,
        "detectable_um_note": "the held-out rms the null's threshold gain removes (or the "
        "practical margin, if more): no effect of the library took more than this off the "
        "held-out rms; it is not an effect size",
        # Per effect: the rms of drift (µm) an effect must have to be named with 80 %
        # power at the first step, over its families (which camera, joint, length).
        "detectable_rms_um_80": _detectable_by_effect(steps[0], cands),
        "tolerances": tolerances[0],
        # False: the rig file states no [tolerances]; the null drew the defaults
        # (docs/tolerances.md: the published metrology each comes from).
        "tolerances_stated": tolerances[2],
        # The factor by which the rig's errors exceed its stated tolerances, estimated
        # from the held-out residual (:mod:`.tolerance_scale`).
        "tolerance_scale": floor.extra.get("tolerance_scale"),
        # Whether the effects of the robot stand out of a rig erring by up to three times its
        # stated tolerances (where the first step found something: .guard).
        "tolerance_excess": floor.extra.get("tolerance_excess"),
        "tolerance_signatures": tolerances[1],
    }


def _detectable_by_effect(step: Step, cands: list[Candidate]) -> dict[str, Any]:
    """Per effect: the smallest and largest per-family detectable rms of drift at 80 % power
    (:attr:`.selection.Step.detectable_by_family`), and the family of each end."""
    effect_of = {c.family.label: c.effect for c in cands}
    by: dict[str, list[tuple[float, str]]] = {}
    for label, size in step.detectable_by_family.items():
        effect = effect_of.get(label, label.split(" ")[0])
        if np.isfinite(size):
            by.setdefault(effect, []).append((size, label))
    out = {}
    for effect, sizes in sorted(by.items()):
        sizes.sort()
        out[effect] = {
            "min_um": sizes[0][0],
            "min_family": sizes[0][1],
            "max_um": sizes[-1][0],
            "max_family": sizes[-1][1],
        }
    return out


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
