"""The sequential diagnosis and its stop rule (issue 48): the error budget against the spending
function's closed form, the truncation against timestamps made here, and the rule on runs of
the independent bench world (:mod:`thermrs.bench.world`) whose truth it did not make."""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.bench.world.cases import make_case
from thermrs.bench.world.world import Campaign
from thermrs.diagnose.sequential import StopRule, spent, truncate_run
from thermrs.errors import InputError

H_NS = 3600 * 10**9


def _pocock(t: float, level: float) -> float:
    """Lan–DeMets' Pocock-type spending function, written out here."""
    return level * math.log(1.0 + (math.e - 1.0) * t)


@pytest.mark.parametrize(
    ("planned", "every", "level"),
    [(24.0, 2.0, 0.05), (15.0, 1.0, 0.05), (15.0, 4.0, 0.01), (10.0, 3.0, 0.1)],
)
def test_the_planned_looks_spend_the_level_and_no_more(
    planned: float, every: float, level: float
) -> None:
    """Over the plan's looks the levels add up to α(1) = level (the union bound's budget),
    each look's level is the closed form's increment, and a last look shorter than the others
    is taken at the plan's end."""
    rule = StopRule(planned_hours=planned, look_every_h=every, level=level)
    levels = rule.planned_levels()
    assert len(levels) == math.ceil(planned / every)
    assert sum(levels) == pytest.approx(level, rel=1e-12)
    assert sum(levels) <= level * (1 + 1e-12)
    hours = [min(every * (k + 1), planned) for k in range(len(levels))]
    cum = np.cumsum(levels)
    for h, c in zip(hours, cum, strict=True):
        assert c == pytest.approx(_pocock(h / planned, level), rel=1e-12)
    assert all(x > 0 for x in levels)


def test_spending_is_clipped_to_the_plan() -> None:
    """No information time past the plan spends more than the level."""
    assert spent(0.0, level=0.05) == 0.0
    assert spent(1.0, level=0.05) == pytest.approx(0.05, rel=1e-15)
    assert spent(3.0, level=0.05) == pytest.approx(0.05, rel=1e-15)
    assert spent(0.5, level=0.05) == pytest.approx(_pocock(0.5, 0.05), rel=1e-15)


def _table(runs: dict[str, float], *, start_h: float = 0.0, every_s: float = 600.0) -> pl.DataFrame:
    """Two cameras' visits of runs that follow one another (hours each)."""
    rows = []
    t = int(1_700_000_000 * 1e9 + start_h * H_NS)
    for name, hours in runs.items():
        n = int(hours * 3600 / every_s)
        for k in range(n):
            for cam in ("A", "B"):
                rows.append((name, cam, t + int(k * every_s * 1e9), 1.0, 2.0))
        t += int(hours * H_NS)
    return pl.DataFrame(rows, schema=["run", "camera", "t_ns", "u_um", "v_um"], orient="row")


def test_truncate_run_keeps_the_first_hours_of_a_recording() -> None:
    """Cut at 5.5 h of a recording of a 4-h run then a 3-h run: every row of the first, the
    first 1.5 h of the second (600 s visits: 9 per camera, the one at exactly 1.5 h left out)."""
    tab = _table({"r1": 4.0, "r2": 3.0})
    cut = truncate_run(tab, hours=5.5)
    assert cut.filter(pl.col("run") == "r1").height == tab.filter(pl.col("run") == "r1").height
    assert cut.filter(pl.col("run") == "r2").height == 2 * 9
    assert truncate_run(tab, hours=0.0).height == 0
    assert truncate_run(tab, hours=100.0).equals(tab)
    with pytest.raises(InputError, match="hours"):
        truncate_run(tab, hours=-1.0)
    with pytest.raises(InputError, match="t_ns"):
        truncate_run(tab.drop("t_ns"), hours=1.0)


def test_a_look_before_there_is_enough_data_spends_nothing() -> None:
    """Two visits per camera: no diagnosis (it needs three), nothing of the budget spent, so
    the next look gets the spending function's whole increment from 0."""
    rule = StopRule(planned_hours=10.0, look_every_h=1.0 / 6.0)
    tab = _table({"hold": 10.0})
    lk = rule.look([tab], tab, thermrs.load_rig(), hours=1.0 / 3.0 - 1e-6)
    assert lk.status == "too little data"
    assert lk.level == 0.0 and lk.level_spent == 0.0 and not lk.stop
    assert rule.spent_so_far == 0.0


def test_bad_options_and_looks_out_of_order_are_refused() -> None:
    with pytest.raises(ValueError, match="planned_hours"):
        StopRule(planned_hours=0.0, look_every_h=1.0)
    with pytest.raises(ValueError, match="look_every_h"):
        StopRule(planned_hours=5.0, look_every_h=6.0)
    with pytest.raises(ValueError, match="level"):
        StopRule(planned_hours=5.0, look_every_h=1.0, level=1.5)
    with pytest.raises(ValueError, match="care_um"):
        StopRule(planned_hours=5.0, look_every_h=1.0, care_um=-1.0)
    rule = StopRule(planned_hours=10.0, look_every_h=1.0)
    tab = _table({"hold": 10.0})
    rule.look([tab], tab, thermrs.load_rig(), hours=0.2)
    with pytest.raises(ValueError, match="not past"):
        rule.look([tab], tab, thermrs.load_rig(), hours=0.2)


def _watch(
    effects: tuple[str, ...],
    snr: float,
    seed: int,
    *,
    hours: float,
    every: float,
    settle_ambiguous: bool = True,
    until_h: float | None = None,
) -> StopRule:
    rig = thermrs.load_rig()
    tables, _, _ = make_case(
        str(rig.source),
        effects,
        snr,
        world="white",
        seed=seed,
        campaign=Campaign(hours=hours, cycle_s=600.0, sigma_um=2.0),
    )
    recording = pl.concat(tables[1:])
    rule = StopRule(planned_hours=2 * hours, look_every_h=every, settle_ambiguous=settle_ambiguous)
    h = 0.0
    while not rule.stopped and (until_h is None or h < until_h):
        h = min(h + every, 2 * hours)
        rule.look(tables[:1], recording, rig, hours=h, seed=seed)
    return rule


@pytest.mark.slow
def test_a_strong_effect_stops_the_recording_early_and_is_named() -> None:
    """A thermal lag at SNR 4 (the world's own lag, not the diagnoser's family) on the bench's
    campaign (12-h runs; the recording is the second day's two, 24 h): the rule settles before
    the plan's end and names the lag; every look ran the diagnoser at the spending function's
    increment. (With 6-h runs, shorter than the lag's time constants, the lag shows mostly in
    the cool-down and is named only in the plan's last hours.)"""
    rule = _watch(("thermal_lag",), 4.0, 4_800_101, hours=12.0, every=2.0)
    last = rule.looks[-1]
    assert last.settled and last.hours < rule.planned_hours
    assert "thermal_lag" in last.named
    prev = 0.0
    for lk in rule.looks:
        assert lk.diagnosis is not None
        want = _pocock(lk.hours / rule.planned_hours, 0.05) - _pocock(prev, 0.05)
        assert lk.level == pytest.approx(want, rel=1e-12)
        assert lk.diagnosis.tests["level"] == pytest.approx(want, rel=1e-12)
        prev = lk.hours / rule.planned_hours


@pytest.mark.slow
def test_an_effect_free_recording_names_nothing_and_runs_to_the_plan() -> None:
    """No effect in the world: no look names one, and a ``none`` does not settle before the
    plan's end (by default the question's conditions are those of the whole plan)."""
    rule = _watch((), 0.0, 4_800_202, hours=4.0, every=2.0)
    assert all(lk.named == () for lk in rule.looks)
    assert all(lk.status != "identified" for lk in rule.looks)
    assert rule.looks[-1].hours == rule.planned_hours
    assert not any(lk.settled for lk in rule.looks)


@pytest.mark.slow
def test_a_designed_run_does_not_stop_on_rivals_it_cannot_tell_apart() -> None:
    """α per link at SNR 2 on the paper rig, whose look-alikes (joint offset, unmodelled
    length) the data cannot reject: with ``settle_ambiguous`` off, as for a run planned to
    separate them, two ambiguous looks in a row do not settle it; with it on they do."""
    loose = _watch(("alpha_per_link",), 2.0, 4_810_005, hours=12.0, every=2.0, until_h=8.0)
    strict = _watch(
        ("alpha_per_link",),
        2.0,
        4_810_005,
        hours=12.0,
        every=2.0,
        settle_ambiguous=False,
        until_h=8.0,
    )
    pairs = [
        (a, b)
        for a, b in zip(strict.looks, strict.looks[1:], strict=False)
        if a.status == b.status == "ambiguous" and a.named == b.named
    ]
    assert pairs, "the case has two ambiguous looks in a row"
    assert not any(lk.settled for lk in strict.looks if lk.status == "ambiguous")
    assert any(lk.settled and lk.status == "ambiguous" for lk in loose.looks)
