"""A sequential diagnosis: the diagnosis run again as a held-out run is recorded, and a rule
that says when its verdict is settled and the recording may stop (issue 48).

Every look runs :func:`thermrs.diagnose.diagnose` on the training runs and the held-out
recording truncated to what is there (:func:`truncate_run`). Looking again and again at data
that grow, and stopping at the first look that says something, would call a world without an
effect otherwise far more often than each look's level: the looks share one error budget.

**The error budget: an alpha-spending function, with the union bound over the looks.** The
planned recording (``planned_hours``: the fixed protocol's length) is the information scale,
``t = hours / planned_hours``. The error spent by ``t`` is the Lan–DeMets Pocock-type function
``α(t) = α·ln(1 + (e − 1)·t)``; a look at ``t_k`` after one at ``t_{k-1}`` runs the diagnoser
at ``level = α(t_k) − α(t_{k-1})``. Whatever the looks' times and however many, the levels
telescope to at most ``α(1) = α``, so by the union bound the chance that *any* look makes a
false claim (an effect named in a world without it, or a false ``none``-with-power, see below)
is at most ``α``. Why this and not the alternatives:

- Exact group-sequential boundaries (O'Brien–Fleming, Pocock by numerical integration) need
  the test statistic across looks to be a Gaussian process with independent increments. The
  diagnosis is a forward selection with bootstrap nulls, floor and whiteness tests, rival
  tests: no such statistic exists, and boundaries computed as if it did carry no guarantee.
  The union bound needs no assumption about how the looks depend on each other.
- Anytime-valid confidence sequences (e-processes) would allow unplanned looks and no plan
  at all, but need a test martingale for every test the diagnoser makes; its tests are
  calibrated by a parametric bootstrap of the whole pipeline, which yields p-values, not
  e-values. Spending over a planned length keeps those tests as they are.
- The Pocock shape spends about evenly over the plan; O'Brien–Fleming's spends almost
  nothing early (α(¼) ≈ 10⁻⁴ at α = 5 %), which a bootstrap cannot resolve without tens of
  thousands of draws a look, and which would forbid the early stops the rule is for.

The union bound is conservative: the levels it gives are smaller than exact boundaries would
be, so each look has a little less power; the price of a guarantee that holds for these tests.
Each look's null has enough draws to resolve its level (:data:`RESOLVE`).

**The stop rule.** A look *settles* the verdict when

- it names effects (``identified``, or ``ambiguous`` unless ``settle_ambiguous`` is off, as
  for a run planned by ``thermrs design`` to separate the rivals) and the look before named
  the same set with the same status (each at its own spent level): a named effect is
  significant at the look's level and stable; or
- it is ``none``, the look before was ``none`` too, the recording is at least ``none_after_h``
  long, and the data had the power to see what the user cares about (``care_um``, an rms of
  drift in µm): every effect of the library (its hardest family) would have been named from
  ``care_um`` with 95 % power. The diagnosis reports the 80 %-power size ``d₈₀``
  (``tests.detectable_rms_um_80``); the gain needed scales as ``d² ∝ z_cut + z_power``
  (:mod:`thermrs.diagnose.selection`), so with the cut ``z_cut ≥ 0`` ``d₉₅ ≤ d₈₀·√(z₀.₉₅ /
  z₀.₈₀) = 1.398·d₈₀`` (:data:`POWER_95_OVER_80`). Without ``care_um`` a ``none`` never settles
  before the plan's end.

  That power is over the hours seen: an effect that shows only in conditions still to come
  (the heating's end, the steady state, a cool-down the plan records later) is not in it, and
  its rms over the part seen may be far below its rms over the plan. So ``none_after_h``, the
  hours by which the recording has been through every condition the question is about, is
  the user's to state, and defaults to the plan's end: by default a ``none`` settles only
  there, and the rule stops early only on named effects.

``unexplained`` and ``partially explained`` never settle early: a gap the library does not
explain is not an answer to stop on. At the plan's end the last look stops whatever it says.

Example
-------
>>> from thermrs.diagnose.sequential import StopRule
>>> rule = StopRule(planned_hours=24.0, look_every_h=2.0, care_um=2.0)
>>> round(sum(rule.planned_levels()), 12)
0.05
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import polars as pl

from thermrs.diagnose import LEVEL, NULL_DRAWS, Diagnosis, diagnose
from thermrs.diagnose.input_checks import MIN_VISITS
from thermrs.errors import InputError
from thermrs.rig import Rig

__all__ = [
    "POWER_95_OVER_80",
    "RESOLVE",
    "Look",
    "StopRule",
    "spent",
    "truncate_run",
]

#: ``√(z₀.₉₅ / z₀.₈₀)``: the bound on the 95 %-power detectable size over the 80 % one
#: (module docs).
POWER_95_OVER_80 = math.sqrt(1.6448536269514722 / 0.8416212335729143)
#: A look's null has at least this many draws per unit of its smallest p-value's resolution:
#: ``null_draws + 1 ≥ RESOLVE / (level / 4)`` (the diagnoser's tests are at level / 4), so a
#: test can reject with up to ``RESOLVE − 1`` null draws beyond the data's statistic.
RESOLVE = 4.0
#: Hours are compared to the plan with this slack (floating-point sums of look intervals).
_EPS_H = 1e-9


def spent(t: float, *, level: float = LEVEL) -> float:
    """The error spent by information time ``t`` (Lan–DeMets Pocock type, module docs).

    Parameters
    ----------
    t
        ``hours / planned_hours``, clipped to [0, 1].
    level
        The error over all the looks.

    Returns
    -------
    float
        ``level·ln(1 + (e − 1)·t)``: 0 at ``t = 0``, ``level`` at ``t = 1``.
    """
    tc = min(max(float(t), 0.0), 1.0)
    return float(level * math.log1p((math.e - 1.0) * tc))


def truncate_run(table: pl.DataFrame, *, hours: float) -> pl.DataFrame:
    """The rows of a run table recorded within ``hours`` of its first visit.

    Parameters
    ----------
    table
        A run table (``t_ns`` column); it may hold several runs of one recording, cut at the
        hours since the table's first visit.
    hours
        Hours since the first visit (rows with ``t_ns < first + hours``); 0 or more.

    Returns
    -------
    polars.DataFrame
        The first rows, in the table's order.

    Raises
    ------
    InputError
        No ``t_ns`` column, or ``hours`` negative or not finite.
    """
    if "t_ns" not in table.columns:
        raise InputError("the held-out recording's table has no `t_ns` column")
    if not (math.isfinite(hours) and hours >= 0):
        raise InputError(f"hours {hours}: give a finite number of hours, 0 or more")
    if table.height == 0:
        return table
    first = int(table["t_ns"].min())  # type: ignore[arg-type]
    end = first + round(hours * 3600.0 * 1e9)
    return table.filter(pl.col("t_ns") < end)


@dataclass(frozen=True)
class Look:
    """One look of a :class:`StopRule`.

    Attributes
    ----------
    hours
        Hours of the held-out recording this look saw.
    level
        The level the diagnoser ran at (this look's share of the error budget; 0 where there
        was too little data to look).
    level_spent
        The error spent by the looks so far, this one included.
    status
        The verdict's outcome (``identified``, ``ambiguous``, ``partially explained``,
        ``unexplained``, ``none``; ``too little data`` without a diagnosis).
    named
        The effects the verdict names (its effect, its confounded set, the effects selected).
    detectable_95_um
        The largest rms of drift (µm) an effect of the library may have and still be missed
        with 5 % chance at this look (module docs); ``None`` without a diagnosis.
    stop
        The recording may stop: the verdict is settled, or the plan's end is reached.
    settled
        The stop rule is met (not only the plan's end).
    message
        What the look says, in a sentence or two.
    diagnosis
        The look's diagnosis (``None`` with too little data).
    """

    hours: float
    level: float
    level_spent: float
    status: str
    named: tuple[str, ...]
    detectable_95_um: float | None
    stop: bool
    settled: bool
    message: str
    diagnosis: Diagnosis | None = field(default=None, repr=False, compare=False)

    def to_json(self) -> dict[str, Any]:
        """The look as a JSON-ready dict (the diagnosis's verdict, not the whole document)."""
        return {
            "hours": self.hours,
            "level": self.level,
            "level_spent": self.level_spent,
            "status": self.status,
            "named": list(self.named),
            "detectable_95_um": self.detectable_95_um,
            "stop": self.stop,
            "settled": self.settled,
            "message": self.message,
            "verdict": None if self.diagnosis is None else self.diagnosis.verdict,
        }


def _named(d: Diagnosis) -> tuple[str, ...]:
    v = d.verdict
    names = [v.get("effect"), *(v.get("confounded_with") or []), *(v.get("effects") or [])]
    return tuple(sorted({str(n) for n in names if n}))


def _detectable_95(d: Diagnosis) -> float | None:
    """The 95 %-power detectable size bound of the hardest family of the library (µm)."""
    sizes = [
        float(e["max_um"])
        for e in (d.tests.get("detectable_rms_um_80") or {}).values()
        if e.get("max_um") is not None and math.isfinite(float(e["max_um"]))
    ]
    return POWER_95_OVER_80 * max(sizes) if sizes else None


def _usable_runs(table: pl.DataFrame) -> list[pl.DataFrame]:
    """The held-out recording split into its runs, each with the visits a diagnosis needs
    per camera (a run just begun is left for a later look)."""
    out = []
    for (_,), part in table.group_by(["run"], maintain_order=True):
        counts = part.group_by("camera").len()["len"]
        if part.height and int(counts.min()) >= MIN_VISITS:  # type: ignore[arg-type]
            out.append(part)
    return out


class StopRule:
    """Looks at a held-out recording as it grows, with the error over every look held at
    ``level`` and a rule that says when the verdict is settled (module docs).

    Parameters
    ----------
    planned_hours
        The fixed protocol: hours of held-out recording the experiment was planned for. The
        error budget is spent over it; the look that reaches it stops.
    look_every_h
        Hours of data between looks (the hours of the next look a message states).
    level
        The error over all the looks.
    care_um
        The smallest rms of drift (µm) the user needs to see: a ``none`` settles only once
        every effect of the library that large would have been named with 95 % power.
        ``None``: a ``none`` settles only at the plan's end.
    none_after_h
        Hours from which a ``none`` may settle: by then the recording has been through every
        thermal condition the question is about (module docs). Default: ``planned_hours``.
    settle_ambiguous
        Whether an ``ambiguous`` verdict (rivals the data cannot reject) may settle. False
        for a run ``thermrs design`` planned to separate them: its question is which one, and
        only ``identified`` answers it.
    min_null_draws
        Null draws of a look at least (more where its level needs them: :data:`RESOLVE`).

    Raises
    ------
    ValueError
        Hours not positive, ``look_every_h`` longer than the plan, ``level`` outside (0, 1),
        ``care_um`` not positive.
    """

    def __init__(
        self,
        *,
        planned_hours: float,
        look_every_h: float,
        level: float = LEVEL,
        care_um: float | None = None,
        none_after_h: float | None = None,
        settle_ambiguous: bool = True,
        min_null_draws: int = NULL_DRAWS,
    ) -> None:
        if not (math.isfinite(planned_hours) and planned_hours > 0):
            raise ValueError(f"planned_hours must be a positive number, got {planned_hours}")
        if not (math.isfinite(look_every_h) and 0 < look_every_h <= planned_hours):
            raise ValueError(
                f"look_every_h must be positive and at most planned_hours ({planned_hours}), "
                f"got {look_every_h}"
            )
        if not 0.0 < level < 1.0:
            raise ValueError(f"level must be between 0 and 1, got {level}")
        if care_um is not None and not (math.isfinite(care_um) and care_um > 0):
            raise ValueError(f"care_um must be a positive number of µm, got {care_um}")
        if none_after_h is not None and not (math.isfinite(none_after_h) and none_after_h > 0):
            raise ValueError(f"none_after_h must be a positive number of hours, got {none_after_h}")
        self.planned_hours = float(planned_hours)
        self.look_every_h = float(look_every_h)
        self.level = float(level)
        self.care_um = care_um
        self.none_after_h = float(planned_hours if none_after_h is None else none_after_h)
        self.settle_ambiguous = bool(settle_ambiguous)
        self.min_null_draws = int(min_null_draws)
        self.looks: list[Look] = []

    def planned_levels(self) -> list[float]:
        """The levels of the looks of the plan, one every ``look_every_h`` up to its end."""
        n = math.ceil(self.planned_hours / self.look_every_h - _EPS_H)
        hours = [min((k + 1) * self.look_every_h, self.planned_hours) for k in range(n)]
        ts = [0.0] + [h / self.planned_hours for h in hours]
        return [
            spent(b, level=self.level) - spent(a, level=self.level)
            for a, b in itertools.pairwise(ts)
        ]

    @property
    def spent_so_far(self) -> float:
        """The error spent by the looks taken."""
        return self.looks[-1].level_spent if self.looks else 0.0

    @property
    def stopped(self) -> bool:
        """Whether a look has said stop."""
        return bool(self.looks) and self.looks[-1].stop

    def null_draws(self, level: float) -> int:
        """Null draws for a look at ``level`` (:data:`RESOLVE`)."""
        return max(self.min_null_draws, math.ceil(RESOLVE / (level / 4.0)) - 1)

    def look(
        self,
        train: Sequence[pl.DataFrame],
        holdout_so_far: pl.DataFrame,
        rig: Rig | str | os.PathLike[str],
        *,
        hours: float,
        exclude: Sequence[str] = (),
        seed: int = 0,
    ) -> Look:
        """Diagnose the recording so far at this look's share of the error budget.

        Parameters
        ----------
        train
            The training runs (complete run tables).
        holdout_so_far
            The held-out recording so far: one table, one run or several recorded one after
            the other (``run`` column); cut at ``hours`` since its first visit.
        rig
            The rig, or the path of its file.
        hours
            Hours of the recording at this look; more than at the last look.
        exclude
            Effects removed from the library (:func:`thermrs.diagnose.diagnose`).
        seed
            Seed of the diagnosis's draws.

        Returns
        -------
        Look
            The look, also appended to :attr:`looks`.

        Raises
        ------
        ValueError
            The rule has already stopped, or ``hours`` is not past the last look's.
        InputError
            Bad runs (:func:`thermrs.diagnose.diagnose`).
        """
        if self.stopped:
            raise ValueError(f"the rule stopped at {self.looks[-1].hours:g} h: no more looks")
        if not (math.isfinite(hours) and hours > 0):
            raise ValueError(f"hours must be a positive number, got {hours}")
        last_h = self.looks[-1].hours if self.looks else 0.0
        if hours <= last_h:
            raise ValueError(f"hours {hours:g} is not past the last look's ({last_h:g} h)")
        from thermrs.rig import as_rig

        rig = as_rig(rig)
        h = min(float(hours), self.planned_hours)
        end = h >= self.planned_hours - _EPS_H
        runs = _usable_runs(truncate_run(holdout_so_far, hours=h))
        if not runs:
            return self._record(self._too_little(h, end=end))
        cum = spent(h / self.planned_hours, level=self.level)
        lvl = cum - self.spent_so_far
        d = diagnose(
            train,
            runs,
            rig,
            exclude=exclude,
            seed=seed,
            level=lvl,
            null_draws=self.null_draws(lvl),
        )
        status = d.outcome
        named = _named(d) if status in ("identified", "ambiguous") else ()
        d95 = _detectable_95(d)
        prev = next((x for x in reversed(self.looks) if x.diagnosis is not None), None)
        settled = self._settles(h, status, named, d95, prev)
        msg = self._message(h, status, named, d95, settled, end, prev)
        lk = Look(
            hours=h,
            level=lvl,
            level_spent=cum,
            status=status,
            named=named,
            detectable_95_um=d95,
            stop=settled or end,
            settled=settled,
            message=msg,
            diagnosis=d,
        )
        return self._record(lk)

    def _record(self, lk: Look) -> Look:
        self.looks.append(lk)
        return lk

    def _too_little(self, h: float, *, end: bool) -> Look:
        """A look at a recording too short for a diagnosis: nothing spent."""
        return Look(
            hours=h,
            level=0.0,
            level_spent=self.spent_so_far,
            status="too little data",
            named=(),
            detectable_95_um=None,
            stop=end,
            settled=False,
            message=f"{h:g} h: too little of the held-out recording yet for a diagnosis "
            f"({MIN_VISITS} visits per camera); nothing of the error budget spent",
        )

    def _settles(
        self,
        h: float,
        status: str,
        named: tuple[str, ...],
        d95: float | None,
        prev: Look | None,
    ) -> bool:
        """The stop rule (module docs): the same verdict as the last look, and either effects
        named or a ``none`` with the power to see ``care_um`` from ``none_after_h`` on."""
        if prev is None or prev.status != status or prev.named != named:
            return False
        if named:
            return status == "identified" or self.settle_ambiguous
        return (
            status == "none"
            and h >= self.none_after_h - _EPS_H
            and self.care_um is not None
            and d95 is not None
            and d95 <= self.care_um
        )

    def _message(
        self,
        h: float,
        status: str,
        named: tuple[str, ...],
        d95: float | None,
        settled: bool,
        end: bool,
        prev: Look | None,
    ) -> str:
        conf = f"{1 - self.level:.0%}".replace("%", " %")
        what = " or ".join(named) if status == "ambiguous" else " and ".join(named)
        if settled and named:
            return (
                f"{what} {status} after {h:g} h (and at the look before, {prev.hours:g} h); "  # type: ignore[union-attr]
                f"with the error over every look held at {self.level:g}, the verdict stands at "
                f"{conf}: further data are not needed"
                + (
                    "; the data cannot tell these apart (thermrs design finds the measurement "
                    "that would)"
                    if status == "ambiguous"
                    else ""
                )
            )
        if settled:
            return (
                f"no effect after {h:g} h (and at {prev.hours:g} h): every effect of the "  # type: ignore[union-attr]
                f"library of {self.care_um:g} µm rms or more would have been named with 95 % "
                f"power (the hardest needs {d95:.2f} µm); the error over every look is held "
                f"at {self.level:g}"
            )
        if end:
            said = f"{status}" + (f" ({what})" if named else "")
            return (
                f"the planned {self.planned_hours:g} h are in: the verdict is {said}, at level "
                f"{self.level - self.spent_so_far:.3g} (what the budget left for this last "
                "look); it had not settled before"
            )
        left = self.planned_hours - h
        nxt = min(h + self.look_every_h, self.planned_hours)
        if status == "ambiguous" and not self.settle_ambiguous:
            return (
                f"{what} at {h:g} h: the data cannot reject the rivals yet, and the question "
                f"is which; open until a look identifies one ({left:g} h of the plan left)"
            )
        if named:
            return (
                f"{what} {status} at {h:g} h (level {self.spent_so_far_after(h):.3g} spent); "
                f"open until a second look agrees: the next, at {nxt:g} h, settles it if it "
                "names the same"
            )
        if status == "none":
            if self.care_um is None:
                return (
                    f"no effect found at {h:g} h; with no size stated that matters "
                    f"(care_um), a none is settled only at the plan's end ({left:g} h left)"
                )
            if h < self.none_after_h - _EPS_H:
                power = (
                    f"one of {self.care_um:g} µm rms would have been seen so far with 95 % power"
                    if d95 is not None and d95 <= self.care_um
                    else f"95 % power so far needs up to {d95:.2f} µm"
                    if d95 is not None
                    else "its power is unknown"
                )
                return (
                    f"no effect found at {h:g} h ({power}); a none is not settled before "
                    f"{self.none_after_h:g} h, when the recording has been through every "
                    "condition the question is about"
                )
            if d95 is not None and d95 > self.care_um:
                # The detectable size shrinks as 1/√hours (the null's spread of a gain,
                # in µm², falls as 1/n): hours·(d95/care)² bring it to care_um.
                need = h * (d95 / self.care_um) ** 2
                when = (
                    f"about {need:.0f} h of recording would bring it under"
                    if need <= self.planned_hours
                    else f"the planned {self.planned_hours:g} h may not bring it under "
                    f"(at 1/√hours: about {need:.0f} h)"
                )
                return (
                    f"no effect found at {h:g} h, but one of {self.care_um:g} µm rms could "
                    f"still be missed (95 % power needs up to {d95:.2f} µm); {when}"
                )
            return (
                f"no effect found at {h:g} h with the power to see {self.care_um:g} µm; "
                f"open until a second look agrees (next at {nxt:g} h)"
            )
        return (
            f"{status} at {h:g} h: a gap the library does not explain (yet); more data sharpen "
            f"every test; {left:g} h of the plan left (next look at {nxt:g} h)"
        )

    def spent_so_far_after(self, hours: float) -> float:
        """The error spent by a look at ``hours``."""
        return spent(min(hours, self.planned_hours) / self.planned_hours, level=self.level)
