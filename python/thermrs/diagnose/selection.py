"""Forward selection of effects, every step a test against its own parametric bootstrap.

Step k takes the model so far (the nominal model, then with the effects already selected) as
the truth of a null world (:mod:`.null`) and scores every remaining family *added to it*:
profiled on its grid by the training residual, scored by the drop of the held-out mean square.
A family is significant when its gain on the data exceeds the (1 − level) quantile of the
largest gain any family reaches in the null world; the most significant plausible one is added
(its non-linear parameters profiled jointly with the model so far), and the next step starts
from the new model. Selection stops when nothing is significant, when what is left is no longer
a gap (at the floor and white at the thermal time scales against the first step's gap-free
world), or when three effects are in.

The first step. Once its other tests show a gap at the step's level, the verdict cannot be
`none` whatever the gains say, so the gains are tested at ``gap_level`` (the verdict's level)
instead of the Bonferroni share `none` needs (closed testing; naming an effect of the robot
still takes the guard, :mod:`.guard`, at the verdict's level: intersection–union).

The guard until an effect of the robot is in. Where a step whose model so far holds no effect
of the robot (none, or the thermal camera's errors) shows a gap and the held-out gains choose
no effect, or one of the robot the guard does not find, while the guard (given the model so
far: its effects' columns free like α) finds effects of the robot, the guard's most
significant family that is plausible and takes at least the practical margin off the held-out
rms (at its grid point on every run) is chosen instead, the other effects it finds its
rivals: a family fitted on the training run alone can miss what every run shows (a non-linear
α's curvature, which a run at one speed hardly shows), and no choice the guard does not find
could be named. Once an effect of the robot is in, the held-out gains choose, as before (and
a step may be taken again with another of their choices: :func:`forward_selection`): the
guard's choices in turn made three effects of a rig erring by three times its tolerances, and
pre-empted that revision, which finds the second effect of a pair.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.accuracy import NOISE_DRAWS, equal_accuracy_p
from thermrs.diagnose.family_fit import DesignMatrix
from thermrs.diagnose.floor import NoiseFloor
from thermrs.diagnose.null import Batch, BatchFit, Observations, draw_noise, quantile_above
from thermrs.effects import Family, is_instrument
from thermrs.signatures import VisitSet

__all__ = ["FamilyGrid", "Step", "build_grids", "forward_selection"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class FamilyGrid:
    """A family with its signature columns at every grid point, computed once."""

    family: Family
    etas: list[dict[str, float]]
    cols: list[FloatArray]
    #: False for an effect outside the library (excluded): never named, scored only as a
    #: rival the data may fail to reject.
    nameable: bool = True


@dataclass
class Choice:
    """A family at its grid point, as selected."""

    grid: FamilyGrid
    index: int

    @property
    def columns(self) -> FloatArray:
        return self.grid.cols[self.index]

    @property
    def eta(self) -> dict[str, float]:
        return self.grid.etas[self.index]

    @property
    def label(self) -> str:
        return self.grid.family.label

    @property
    def effect(self) -> str:
        return self.grid.family.effect


@dataclass
class Step:
    """One step of the selection: the model so far tested against its null, and what the
    families gain on it."""

    model: list[Choice]
    hold_ms: float
    p_at_floor: float
    p_low: float
    p_gain: float
    p_floor_contradicted: float
    gain: dict[str, float]
    gain_p: dict[str, float]
    best_index: dict[str, int]
    threshold: float
    significant: list[str] = field(default_factory=list)
    chosen: Choice | None = None
    rivals: list[str] = field(default_factory=list)
    rival_p: dict[str, float] = field(default_factory=dict)
    #: Rivals (in :attr:`rivals`) from outside the library: excluded effects that explain the
    #: gap as well as the chosen one and that the data cannot reject.
    outside: list[str] = field(default_factory=list)
    #: The chosen effect's other discrete choices (family labels: another joint, temperature,
    #: length or camera) tested as the truth, and those the data cannot reject.
    #: Per alternative: the p of its test (:func:`_rival_p` with equal accuracy), and that of
    #: the equal-accuracy part alone.
    alt_p: dict[str, float] = field(default_factory=dict)
    alt_p_accuracy: dict[str, float] = field(default_factory=dict)
    alternatives: list[str] = field(default_factory=list)
    null_hold_ms: FloatArray = field(default_factory=lambda: np.zeros(0))
    low: float = 0.0
    null_low: FloatArray = field(default_factory=lambda: np.zeros(0))
    #: The held-out rms (µm) a family must remove to be named at this step: what the null's
    #: threshold gain removes, or the practical margin if that is more.
    detectable_um: float = 0.0
    #: The practical margin this step used (µm): given, or the floor's standard error.
    margin_um: float = 0.0
    #: Per family (label): the rms of drift (µm) an effect of that family must have to be
    #: named at this step with 80 % power: its held-out gain (≈ the effect's own mean square
    #: once fitted) must clear the family's bar by the null's spread times z₀.₈ (a normal
    #: approximation, the gain's spread under the effect taken as the null's).
    detectable_by_family: dict[str, float] = field(default_factory=dict)
    draws: int = 0
    #: What chose the step's effect: the held-out gains, or the every-run test against a rig
    #: erring by more than it states where they chose none it finds (:func:`run_step`).
    chosen_by: str = "held-out gain"
    #: The level the families' gains were tested at: the selection's, or the verdict's where
    #: the step's other tests had already shown a gap (:func:`run_step`'s ``gap_level``).
    gain_level: float = 0.0
    rival_draws: int = 0
    #: The null world's held-out mean squares with the model's last effect re-profiled on its
    #: grid in every replicate (its non-linear parameters' estimation error included).
    null_hold_ms_profiled: FloatArray = field(default_factory=lambda: np.zeros(0))


def build_grids(
    families: list[Family], visits: VisitSet, design: DesignMatrix, *, nameable: bool = True
) -> list[FamilyGrid]:
    """Every family's columns at every grid point that can act on these runs."""
    out = []
    for fam in families:
        etas, cols = [], []
        try:
            for eta in design.grid(fam):
                c = fam.columns(visits, eta)
                if not np.all(np.isfinite(c)) or design.identifiable(c) < 1e-6:
                    continue
                etas.append(dict(eta))
                cols.append(np.asarray(c, dtype=np.float64))
        except Exception:  # an effect that cannot act on these runs
            continue
        if etas:
            out.append(FamilyGrid(fam, etas, cols, nameable))
    return out


def _stack(model: list[Choice], extra: FloatArray | None = None) -> FloatArray | None:
    parts = [c.columns for c in model]
    if extra is not None:
        parts.append(extra)
    return np.column_stack(parts) if parts else None


def _profile(
    batch: Batch, model: list[Choice], fg: FamilyGrid, ys: FloatArray | Observations
) -> tuple[FloatArray, npt.NDArray[np.intp]] | None:
    """Held-out mean square per column of ``y`` of the family added to the model, at the grid
    point with the least training residual for that column."""
    y = ys if isinstance(ys, Observations) else batch.prepare(ys)
    rss, hms = [], []
    width = y.y.shape[1]
    nested = batch.nested(model, _stack(model), y)
    for c in fg.cols:
        f = None if nested is None else batch.fit_added(nested, c, y)
        if f is None:
            rss.append(np.full(width, np.inf))
            hms.append(np.full(width, np.nan))
        else:
            rss.append(f.train_rss)
            hms.append(f.hold_ms)
    r = np.vstack(rss)
    if not np.any(np.isfinite(r[:, 0])):
        return None
    best = np.argmin(r, axis=0)
    return np.vstack(hms)[best, np.arange(width)], best


def _world(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    model: list[Choice],
    draws: int,
    rng: np.random.Generator,
) -> tuple[FloatArray, BatchFit]:
    """The data and ``draws`` replicates of the world where ``model`` is the truth."""
    y = design.y[:, None]
    obs = batch.fit(_stack(model), y, keep=True)
    if obs is None or obs.fitted is None or obs.coef is None:
        raise np.linalg.LinAlgError("the model cannot be fitted")
    sim = obs.fitted + draw_noise(design, floor, draws, rng)
    # The user's world: a rig within its stated tolerances, not the file's exact one; about
    # a model with effects, its IR readings' errors move its effects too (.tolerances).
    nuis = design.nuisance
    if model and design.model_nuisance is not None and nuis.shape[1]:
        terms = [(c.grid.family, c.eta, c.columns) for c in model]
        nuis = design.model_nuisance.of(terms, obs.coef[:, 0])
    if nuis.shape[1]:
        sim = sim + nuis @ rng.standard_normal((nuis.shape[1], draws))
    ys = np.column_stack([y, sim])
    cur = batch.fit(_stack(model), ys)
    assert cur is not None
    return ys, cur


def run_step(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    grids: list[FamilyGrid],
    model: list[Choice],
    *,
    level: float,
    draws: int,
    rng: np.random.Generator,
    plausible: Callable[[list[Choice], Choice], bool],
    margin_um: float | None = 0.0,
    prefer: str | None = None,
    gap_level: float | None = None,
    guard: Callable[[FloatArray | None, frozenset[str]], dict[str, Any]] | None = None,
) -> Step:
    """Test the model against its null world and score every family added to it. A family
    is significant when its held-out gain beats the null's threshold *and* it takes at least
    ``margin_um`` off the held-out rms (practical significance). The family chosen is the
    significant one that leaves least, or ``prefer`` (a label) where it is significant;
    ``gap_level`` and ``guard``: module docs ("The first step", "The guard until ...")."""
    ys_raw, cur = _world(batch, design, floor, model, draws, rng)
    if not model and floor.holdout_se_um is None:
        _floor_uncertainty(batch, design, floor, ys_raw, cur)
    if margin_um is None:
        # What the held-out runs resolve at the floor: an effect that takes less off the
        # held-out rms than the floor's own standard error is not told from the floor's
        # estimation. It shrinks as runs grow longer, so power grows with data.
        margin_um = float(floor.holdout_se_um or 0.0)
    ys = batch.prepare(ys_raw)
    assert cur.hold_resid is not None
    low = batch.low(cur.hold_resid)
    sc = _Scores.of(batch, model, grids, ys, cur)
    gains, hold = sc.gains, sc.hold
    centre, spread = _studentizers(gains)
    z = {k: (v - centre[k]) / spread[k] for k, v in gains.items()}
    # The bar and the tests of the model so far are the library's: an effect outside it
    # (excluded) is only ever a rival.
    named = [k for k in gains if sc.by_label[k].nameable]
    if named:
        max_null = np.nanmax(np.vstack([z[k] for k in named])[:, 1:], axis=0)
        min_hold_null = np.nanmin(np.vstack([hold[k] for k in named])[:, 1:], axis=0)
        obs_min_hold = float(np.nanmin([hold[k][0] for k in named]))
    else:
        max_null = np.zeros(draws)
        min_hold_null = cur.hold_ms[1:]
        obs_min_hold = float(cur.hold_ms[0])
    p_at_floor = quantile_above(cur.hold_ms[1:], float(cur.hold_ms[0]))
    p_low = quantile_above(low[1:], float(low[0]))
    # How often the null's best candidate leaves as little as the data's best does.
    p_contradicted = float((1 + np.sum(min_hold_null <= obs_min_hold)) / (len(min_hold_null) + 1))
    gap = min(p_at_floor, p_low, p_contradicted) < level
    gain_level = max(level, gap_level) if gap_level is not None and gap else level
    z_cut = float(np.quantile(max_null, 1.0 - gain_level))
    # Each family's bar in µm² (its gain at the studentized cut).
    bars = {k: centre[k] + z_cut * spread[k] for k in gains}
    threshold = max((bars[k] for k in named), default=0.0)
    h0 = float(cur.hold_ms[0])
    detectable = float(np.sqrt(h0) - np.sqrt(max(h0 - threshold, 0.0)))
    step = Step(
        model=list(model),
        hold_ms=float(cur.hold_ms[0]),
        p_at_floor=p_at_floor,
        p_low=p_low,
        p_gain=quantile_above(max_null, max((float(z[k][0]) for k in named), default=0.0)),
        p_floor_contradicted=p_contradicted,
        gain={k: float(gains[k][0]) for k in named},
        gain_p={k: quantile_above(max_null, float(z[k][0])) for k in named},
        best_index=sc.best_idx,
        threshold=threshold,
        null_hold_ms=cur.hold_ms[1:],
        low=float(low[0]),
        null_low=low[1:],
        detectable_um=max(detectable, margin_um),
        detectable_by_family={
            k: float(np.sqrt(max((z_cut + Z_POWER_80) * spread[k], 0.0))) for k in named
        },
        draws=draws,
        gain_level=gain_level,
    )
    step.margin_um = margin_um
    if model:
        again = _profile(batch, model[:-1], model[-1].grid, ys)
        if again is not None:
            step.null_hold_ms_profiled = again[0][1:]
    sig = sc.significant(bars, model, plausible, removes=np.sqrt(h0) - margin_um)
    ok = [c for c in sig if c.grid.nameable]
    ok.sort(key=lambda c: c.label != prefer)  # stable: the preferred one first, if there
    if guard is not None and gap:
        adm = _admissible(batch, design, cur, model, plausible, margin_um)
        ok = _guarded_choices(ok, guard, model, grids, adm)
        if ok and ok[0].label not in {c.label for c in sig}:
            step.chosen_by = "guard"
    step.significant = [c.label for c in ok]
    if not ok:
        return step
    step.chosen = ok[0]
    outside = [c for c in sig if not c.grid.nameable]
    _test_rivals(step, ok, outside, batch, design, floor, model, level=level, draws=draws, rng=rng)
    return step


def _studentizers(gains: dict[str, FloatArray]) -> tuple[dict[str, float], dict[str, float]]:
    """Each family's null centre and spread (median, MAD): its gain is studentized by them
    before the maximum, so that a family unstable once the model so far is in (a wide null)
    cannot set the bar for the others."""
    centre: dict[str, float] = {}
    spread: dict[str, float] = {}
    for k, v in gains.items():
        null = v[1:][np.isfinite(v[1:])]
        centre[k] = float(np.median(null)) if len(null) else 0.0
        mad = float(np.median(np.abs(null - centre[k]))) * 1.4826 if len(null) else 0.0
        spread[k] = max(mad, float(np.std(null)) * 0.1, 1e-12)
    return centre, spread


def _admissible(
    batch: Batch,
    design: DesignMatrix,
    cur: BatchFit,
    model: list[Choice],
    plausible: Callable[[list[Choice], Choice], bool],
    margin_um: float,
) -> Callable[[Choice], bool]:
    """Whether a choice added to ``model`` is plausible and takes at least ``margin_um`` off
    the held-out rms (the practical significance the held-out gains' choices need too)."""

    def ok(ch: Choice) -> bool:
        if ch.effect in {c.effect for c in model} or not plausible(model, ch):
            return False
        got = batch.fit(_stack([*model, ch]), design.y[:, None])
        if got is None:
            return False
        after = np.sqrt(max(float(got.hold_ms[0]), 0.0))
        return bool(after < np.sqrt(max(float(cur.hold_ms[0]), 0.0)) - margin_um)

    return ok


def _guarded_choices(
    ok: list[Choice],
    guard: Callable[[FloatArray | None, frozenset[str]], dict[str, Any]],
    model: list[Choice],
    grids: list[FamilyGrid],
    admissible: Callable[[Choice], bool],
) -> list[Choice]:
    """A step's candidates, the chosen first: the held-out gains' (``ok``) unless they choose
    no effect, or one of the robot the guard (:mod:`.guard`, given ``model``) does not find,
    while it finds effects of the robot; then the guard's families of the effects it
    finds that are ``admissible`` (plausible, and taking the practical margin off the
    held-out rms at the guard's grid point), the most significant first, and the thermal
    camera's candidates among ``ok`` (which the guard does not test) as their rivals."""
    if ok and is_instrument(ok[0].effect):
        return ok
    found = guard(_stack(model), frozenset(c.effect for c in model))
    sig = set(found.get("significant_effects") or []) if found.get("tested") else set()
    if not sig or (ok and ok[0].effect in sig):
        return ok
    by_label = {g.family.label: g for g in grids if g.nameable}
    picks = []
    for e, b in (found.get("best") or {}).items():
        g = by_label.get(b["family"])
        if e in sig and g is not None:
            ch = Choice(g, int(b["index"]))
            if admissible(ch):
                picks.append(ch)
    if not picks:
        return ok
    return [*picks, *(c for c in ok if is_instrument(c.effect))]


#: The standard normal quantile of 80 % power (per-family detectable sizes).
Z_POWER_80 = 0.8416212335729143

#: Null replicates the floor is re-estimated on for its uncertainty.
FLOOR_DRAWS = 49


def _floor_uncertainty(
    batch: Batch, design: DesignMatrix, floor: NoiseFloor, ys_raw: FloatArray, cur: BatchFit
) -> None:
    """The held-out floor's standard error and 95 % interval, from the floor re-estimated on
    replicates of the gap-free world (residuals of the nominal refit)."""
    from thermrs.diagnose.floor import holdout_floor_draws

    assert cur.hold_resid is not None
    k = min(FLOOR_DRAWS, cur.hold_resid.shape[1] - 1)
    if k < 5 or not np.isfinite(floor.holdout_um):
        return
    hold_runs = set(np.concatenate([design.vs.run, design.vs.run])[design.hold].tolist())
    est = holdout_floor_draws(
        design.vs, batch.ho, cur.hold_resid[:, 1 : 1 + k], hold_runs, floor.tau_c_max_s
    )
    est = est[np.isfinite(est)]
    if len(est) < 5:
        return
    se = float(np.std(est, ddof=1))
    floor.holdout_se_um = se
    floor.holdout_ci95 = (max(floor.holdout_um - 1.96 * se, 0.0), floor.holdout_um + 1.96 * se)


@dataclass
class _Scores:
    """Each family not yet in the model, added to it at its best grid point, on the data
    (column 0) and on every null replicate: its gain in held-out mean square and what it
    leaves, by family label."""

    gains: dict[str, FloatArray] = field(default_factory=dict)
    hold: dict[str, FloatArray] = field(default_factory=dict)
    best_idx: dict[str, int] = field(default_factory=dict)
    by_label: dict[str, FamilyGrid] = field(default_factory=dict)

    @classmethod
    def of(
        cls,
        batch: Batch,
        model: list[Choice],
        grids: list[FamilyGrid],
        ys: Observations,
        cur: BatchFit,
    ) -> _Scores:
        sc = cls()
        in_model = {c.effect for c in model}
        for fg in grids:
            if fg.family.effect in in_model:
                continue
            got = _profile(batch, model, fg, ys)
            if got is None:
                continue
            hm, idx = got
            sc.gains[fg.family.label] = cur.hold_ms - hm
            sc.hold[fg.family.label] = hm
            sc.best_idx[fg.family.label] = int(idx[0])
            sc.by_label[fg.family.label] = fg
        return sc

    def significant(
        self,
        bars: dict[str, float],
        model: list[Choice],
        plausible: Callable[[list[Choice], Choice], bool],
        *,
        removes: float = np.inf,
    ) -> list[Choice]:
        """The families whose gain on the data beats their ``bars`` (µm²), that leave a
        held-out rms of at most ``removes`` and that are plausible, the one leaving least
        first."""
        sig = [
            k
            for k, v in self.gains.items()
            if v[0] > bars[k] and np.sqrt(max(float(self.hold[k][0]), 0.0)) <= removes
        ]
        sig.sort(key=lambda k: float(self.hold[k][0]))
        ok = []
        for k in sig:
            ch = Choice(self.by_label[k], self.best_idx[k])
            if plausible(model, ch):
                ok.append(ch)
        return ok


def _test_rivals(
    step: Step,
    ok: list[Choice],
    outside: list[Choice],
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    model: list[Choice],
    *,
    level: float,
    draws: int,
    rng: np.random.Generator,
) -> None:
    """One candidate per other effect name: can the data reject it as the truth? Every rival
    is tested, the family by Holm's step-down at the level: an `identified` claims that all
    of them are rejected together. Rivals come from the library (``ok``, the chosen first)
    and from outside it (``outside``: significant, plausible families of excluded effects,
    which can never be named but, kept, stop the chosen one from being called the cause).
    Fills ``step.rival_p``, ``step.rivals`` and ``step.outside``."""
    best = ok[0]
    seen = {best.effect}
    rivals = []
    for ch in [*ok[1:], *outside]:
        if ch.effect not in seen:
            seen.add(ch.effect)
            rivals.append(ch)
    if not rivals:
        return
    k = len(rivals)
    # Enough draws that the smallest cut (level / k) lies inside what they resolve: 1/(B+1)
    # at most half of it.
    n = max(draws, int(np.ceil(2.0 * k / level)) - 1)
    step.rival_draws = n
    for ch in rivals:
        p, _ = _rival_p(batch, design, floor, model, best, ch, draws=n, rng=rng)
        step.rival_p[ch.effect] = p
    # Holm's step-down: the smallest p against level / k, the next against level / (k − 1),
    # … until one is kept; it and every larger one are rivals the data cannot reject. The
    # rivals are rejected together at the level, as with Bonferroni, with more power.
    step.rivals = holm_kept(step.rival_p, level)
    out = {ch.effect for ch in outside}
    step.outside = [e for e in step.rivals if e in out]


#: The chosen effect's other discrete choices are tested as the truth this many at a time (the
#: best fitting first), at most :data:`ALTERNATIVES_CAP` of them.
MAX_ALTERNATIVES = 3
ALTERNATIVES_CAP = 12


def _test_alternatives(
    steps: list[Step],
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    grids: list[FamilyGrid],
    *,
    level: float,
    draws: int,
    rng: np.random.Generator,
) -> None:
    """Each selected effect's other discrete choices (its other families: another joint,
    temperature, length or camera), with the other selected effects in the model: the
    :data:`MAX_ALTERNATIVES` that leave least on the data, each tested as the truth like a
    rival, by Holm's step-down at the level; the ones kept are the choices the data cannot
    tell from the one named. Fills ``alt_p`` and ``alternatives`` of the step that chose it."""
    chosen = [s.chosen for s in steps if s.chosen is not None]
    ys = batch.prepare(design.y[:, None])
    for st in steps:
        best = st.chosen
        if best is None:
            continue
        others = [c for c in chosen if c is not best]
        screened = []
        for fg in grids:
            if not fg.nameable or fg.family.effect != best.effect or fg is best.grid:
                continue
            got = _profile(batch, others, fg, ys)
            if got is not None and np.isfinite(got[0][0]):
                screened.append((float(got[0][0]), Choice(fg, int(got[1][0]))))
        screened.sort(key=lambda t: t[0])
        # The choices that fit best first, :data:`MAX_ALTERNATIVES` at a time, on while every
        # one tested is kept (one the data cannot reject may lie further down).
        pool = [c for _, c in screened[:ALTERNATIVES_CAP]]
        tested = 0
        while tested < len(pool):
            block = pool[tested : tested + MAX_ALTERNATIVES]
            tested += len(block)
            n = max(draws, int(np.ceil(2.0 * tested / level)) - 1)
            for ch in block:
                ps = _rival_p(
                    batch, design, floor, others, best, ch, draws=n, rng=rng, accuracy=True
                )
                st.alt_p[ch.label], st.alt_p_accuracy[ch.label] = ps
            if any(st.alt_p[c.label] < level / tested for c in block):
                break
        st.alternatives = holm_kept(st.alt_p, level)


def holm_kept(p: dict[str, float], level: float) -> list[str]:
    """Holm's step-down over the hypotheses ``p`` (name → p-value): the smallest against
    level / k, the next against level / (k − 1), … until one is kept; it and every larger one
    are the hypotheses kept (not rejected), smallest p first. All are rejected together at
    the level, as with Bonferroni, with more power."""
    order = sorted(p, key=lambda e: p[e])
    k = len(order)
    for i, e in enumerate(order):
        if p[e] >= level / (k - i):
            return order[i:]
    return []


def _rival_p(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    model: list[Choice],
    best: Choice,
    rival: Choice,
    *,
    draws: int,
    rng: np.random.Generator,
    accuracy: bool = False,
) -> tuple[float, float]:
    """Can the data reject ``rival`` as the truth, ``best`` chosen? P(best's held-out
    advantage over the rival ≥ the observed one | the rival, as the library writes it, is
    the truth of a null world at the floor); with ``accuracy`` (an effect's other choices),
    the larger of that and :mod:`.accuracy`'s p (intersection–union; why: that module).
    Returns the p and the equal-accuracy p (NaN without ``accuracy``)."""
    ys_raw, _ = _world(batch, design, floor, [*model, rival], draws, rng)
    ys = batch.prepare(ys_raw)
    a = _profile(batch, model, best.grid, ys)
    b = _profile(batch, model, rival.grid, ys)
    if a is None or b is None:
        return 1.0, 1.0
    d = b[0] - a[0]
    p_exact = quantile_above(d[1:], float(d[0]))
    if not accuracy:
        return p_exact, float("nan")
    fitted = [
        _stack([*model, Choice(c.grid, int(got[1][0]))]) for c, got in ((best, a), (rival, b))
    ]
    p_acc = _accuracy_p(batch, design, floor, fitted, rng)
    return max(p_exact, p_acc), p_acc


def _accuracy_p(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    fitted: list[FloatArray | None],
    rng: np.random.Generator,
) -> float:
    """Equal predictive accuracy of two models (their ``fitted`` columns: the chosen one's,
    the rival's, each at its grid point on the data) on the held-out runs, given the runs
    (:mod:`.accuracy`), the noise drawn from the floor's model."""
    y = design.y[:, None]
    fa, fb = (batch.fit(cols, y) for cols in fitted)
    if fa is None or fb is None or fa.hold_resid is None or fb.hold_resid is None:
        return 1.0
    noise = draw_noise(design, floor, NOISE_DRAWS, rng)[batch.ho]
    return equal_accuracy_p(fa.hold_resid[:, 0], fb.hold_resid[:, 0], noise)


#: At most this many of a step's significant families are tried as its revised choice.
REVISION_POOL = 30


def _revision(
    batch: Batch, design: DesignMatrix, grids: list[FamilyGrid], prev: Step, model: list[Choice]
) -> str | None:
    """A better last choice: among the families significant at the previous step (each at
    its best grid point there), the pair (A, B) of two effects, A in place of the last
    choice, that leaves the least held-out mean square on the data; A's label if that pair
    leaves less than the last choice with any of them, on every held-out run when chosen
    without it. Forward selection's known failure: two effects at once, the first step takes
    a family that mimics a part of both, and with it neither is left to find.

    Chosen by the held-out runs among hundreds of pairs, a pair may only be the best fit to
    what the library cannot explain in them, and every test after it would take that
    search's luck for evidence. So each held-out run judges a choice made without it (on the
    other held-out runs, or on the training runs where it is the only one): the pair is taken
    only where every such choice leaves less on the run left out than the last choice does."""
    by_label = {g.family.label: g for g in grids if g.nameable}
    pool = [
        Choice(by_label[k], prev.best_index[k])
        for k in prev.significant[:REVISION_POOL]
        if k in by_label and k in prev.best_index
    ]
    if len(pool) < 2:
        return None
    base = model[:-1]
    ys = batch.prepare(design.y[:, None])
    runs = design.cluster[batch.ho]
    names = sorted(set(runs.tolist()))
    masks = [runs == r for r in names]

    def scores(a: Choice, b: Choice) -> FloatArray:
        """Training RSS, the held-out mean square, and each held-out run's mean square."""
        f = batch.fit(_stack([*base, a, b]), ys)
        if f is None or f.hold_resid is None:
            return np.full(2 + len(names), np.inf)
        r2 = f.hold_resid[:, 0] ** 2
        return np.array([f.train_rss[0], f.hold_ms[0], *(np.mean(r2[m]) for m in masks)])

    last = model[-1]
    now = np.array([scores(last, b) for b in pool if b.effect != last.effect])
    pairs: list[tuple[Choice, FloatArray]] = []
    # Each pair once, A the one the previous step ranked first.
    for i, a in enumerate(pool):
        if a.label == last.label:
            continue
        for b in pool[i + 1 :]:
            if b.effect == a.effect or b.label == last.label:
                continue
            pairs.append((a, scores(a, b)))
    if not len(now) or not pairs:
        return None
    got = np.array([s for _, s in pairs])
    best = int(np.argmin(got[:, 1]))
    if got[best, 1] >= np.min(now[:, 1]):
        return None
    n_ho = np.array([np.sum(m) for m in masks], dtype=float)
    for k in range(len(names)):
        if len(names) > 1:
            # The other held-out runs' mean square: their rows' share of the sum of squares.
            rest = [j for j in range(len(names)) if j != k]
            w = n_ho[rest] / n_ho[rest].sum()
            pick, ref = got[:, 2 + np.array(rest)] @ w, now[:, 2 + np.array(rest)] @ w
        else:
            pick, ref = got[:, 0], now[:, 0]
        if got[int(np.argmin(pick)), 2 + k] >= now[int(np.argmin(ref)), 2 + k]:
            return None
    return pairs[best][0].label


def forward_selection(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    grids: list[FamilyGrid],
    *,
    level: float,
    draws: int,
    rng: np.random.Generator,
    plausible: Callable[[list[Choice], Choice], bool],
    max_effects: int = 3,
    margin_um: float | None = 0.0,
    gap_level: float | None = None,
    guard: Callable[[FloatArray | None, frozenset[str]], dict[str, Any]] | None = None,
    say: Callable[[str], object] = lambda _m: None,
) -> list[Step]:
    """The selection's steps (module docs); the last step tests the final model. The first
    step's gains are tested at ``gap_level`` where its other tests show a gap, and ``guard``
    may choose a step's effect (:func:`run_step`)."""
    steps: list[Step] = []
    model: list[Choice] = []
    revised: set[int] = set()
    prefer: str | None = None
    while True:
        say(f"step {len(steps) + 1}: testing {len(model)} effect(s) against the null")
        st = run_step(
            batch,
            design,
            floor,
            grids,
            model,
            level=level,
            draws=draws,
            rng=rng,
            plausible=plausible,
            margin_um=margin_um,
            prefer=prefer,
            gap_level=gap_level if not model else None,
            # Until an effect of the robot is in: past that, the held-out gains (and the
            # revision of their choices) choose, as before the guard could.
            guard=guard if all(is_instrument(c.effect) for c in model) else None,
        )
        prefer = None
        steps.append(st)
        if st.chosen is None and model and len(model) - 1 not in revised:
            gap = quantile_above(steps[0].null_hold_ms, st.hold_ms) < level or (
                quantile_above(steps[0].null_low, st.low) < level
            )
            alt = _revision(batch, design, grids, steps[-2], model) if gap else None
            if alt is not None:
                # The last choice was one of several significant families, and with it no
                # second effect is significant while a gap is left; another of them leaves
                # room for one: take the step again with that choice.
                revised.add(len(model) - 1)
                say(f"step {len(steps) - 1} again with {alt} instead of {model[-1].label}")
                steps = steps[:-2]
                model = model[:-1]
                prefer = alt
                continue
        # After the first step an effect is added only while what is left is still a gap:
        # above the floor or slow at the thermal time scales, judged against the gap-free
        # world of the first step (past that, a significant gain is the nuisances' own).
        gap_left = len(steps) == 1 or (
            quantile_above(steps[0].null_hold_ms, st.hold_ms) < level
            or quantile_above(steps[0].null_low, st.low) < level
        )
        if st.chosen is None or len(model) + 1 > max_effects or not gap_left:
            if st.chosen is not None:
                st.chosen = None  # stop here; the step still tests the model
                st.rivals = []
                st.outside = []
            break
        model = [*model, st.chosen]
    say("testing the selected effects' other choices")
    _test_alternatives(steps, batch, design, floor, grids, level=level, draws=draws, rng=rng)
    return steps
