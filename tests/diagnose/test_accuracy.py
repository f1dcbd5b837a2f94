"""The equal-accuracy test of two fitted predictions, given the runs: at its level where the two
predict equally well by construction, under noise correlated across a cycle's channels and from
cycle to cycle (the noise's draws given to it come from the same law, independent of the data),
and rejecting a prediction that is worse."""

from __future__ import annotations

import numpy as np
import thermrs
from thermrs.bench import make_runs
from thermrs.diagnose.accuracy import equal_accuracy_p
from thermrs.diagnose.resample import cycle_units
from thermrs.signatures import VisitSet


def _world(rig: thermrs.Rig) -> tuple[VisitSet, np.ndarray, np.ndarray]:
    runs = make_runs(rig, None, seed=3, hours=6.0, cycle_s=300.0, perturb=False)
    vs = VisitSet(runs, rig)
    return vs, cycle_units(vs), np.concatenate([vs.t_since_start, vs.t_since_start])


def _noise(vs: VisitSet, units: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One AR(1) (φ 0.7 per cycle) shared by every channel of a cycle, plus white noise."""
    c = np.zeros(vs.n)
    for r in np.unique(vs.run):
        m = vs.run == r
        cyc, inv = np.unique(units[m], return_inverse=True)
        x = np.empty(len(cyc))
        x[0] = rng.standard_normal()
        for i in range(1, len(cyc)):
            x[i] = 0.7 * x[i - 1] + np.sqrt(1 - 0.49) * rng.standard_normal()
        c[m] = x[inv]
    return np.concatenate([c, c]) + 0.5 * rng.standard_normal(2 * vs.n)


def _equal_pair(
    rig: thermrs.Rig, seed: int
) -> tuple[VisitSet, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.random.Generator]:
    """The world, 400 draws of its noise, and a slow model error δ: +δ in one prediction and
    −δ in the other, E[(e + δ)²] = E[(e − δ)²], the two equally accurate exactly, while their
    loss differential −4eδ carries the noise's correlation."""
    vs, units, t = _world(rig)
    rng = np.random.default_rng(seed)
    draws = np.column_stack([_noise(vs, units, rng) for _ in range(400)])
    delta = 0.6 * np.sin(2 * np.pi * t / (3 * 3600.0))
    return vs, units, t, draws, delta, rng


def test_two_predictions_equally_accurate_are_told_apart_at_the_level_and_a_worse_one_is_not_missed(
    paper_rig: thermrs.Rig,
) -> None:
    vs, units, t, draws, delta, rng = _equal_pair(paper_rig, 11)
    n = 400
    p_equal = np.empty(n)
    p_worse = np.empty(n)
    for i in range(n):
        e = _noise(vs, units, rng)
        best = e + delta
        p_equal[i] = equal_accuracy_p(best, e - delta, draws)
        # A rival 1.5 µm off besides (a two-hour square wave): worse by about 2.25 µm² in
        # mean square.
        worse = e - delta + 1.5 * np.sign(np.cos(2 * np.pi * t / 7200.0))
        p_worse[i] = equal_accuracy_p(best, worse, draws)
    # At 5 %: the binomial's 99.9 % range over 400 worlds is 9–33 rejections.
    rejected = int(np.sum(p_equal < 0.05))
    assert 9 <= rejected <= 33, rejected
    assert np.mean(p_worse < 0.05) >= 0.9


def test_the_gain_s_standard_error_is_the_spread_of_the_gain_over_worlds(
    paper_rig: thermrs.Rig,
) -> None:
    # Two fixed predictions (a slow ±δ), the held-out noise drawn again world after world
    # (AR(1) across cycles, shared by a cycle's channels): the gain's spread over the worlds
    # against the standard error `gain_z` divides by, from independent draws of the same law.
    # (The moving-block bootstrap of whole cycles it replaces read it about a third low.)
    from thermrs.diagnose.accuracy import gain_se

    vs, units, _, draws, delta, rng = _equal_pair(paper_rig, 5)
    gains = []
    ses = []
    for _ in range(300):
        e = _noise(vs, units, rng)
        r_a, r_b = e + delta, e - delta
        gains.append(float(np.mean(r_b**2 - r_a**2)))
        ses.append(gain_se(r_a, r_b, draws))
    # 300 worlds: the spread's own standard error is about 4 %; the draws' 400 about 3.5 %.
    assert abs(np.median(ses) / np.std(gains, ddof=1) - 1.0) < 0.15
