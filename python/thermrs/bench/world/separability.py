"""How well *any* test could tell a case's effect from each other effect: a bound from the
world alone, for the bench's strict scoring.

A diagnosis is strictly right when it names the true effect alone, which needs every other
effect of SPEC §6 rejected as the explanation. Whatever the test, rejecting a rival family at
level ``level`` when the truth is the world's effect is at most as likely as the most powerful
test of the *simple* hypothesis "the rival's closest member is the truth" against the truth
(Neyman–Pearson). With Gaussian visit errors that power is ``Φ(√λ − z₁₋ₗₑᵥₑₗ)``, where
``λ = ‖(I − P) d‖² / σ²``: ``d`` the effect's noise-free signature on every row of the three
runs (the case rendered without visit errors, with and without the effect), ``P`` the
projection on the rival's signature columns with α and a per-series offset (the nominal
model's own freedom), ``σ²`` the variance of the visit errors' white part (the world's
AR(1) pose errors only add to it, so dividing by the white part alone can only overstate λ).

Every signature is rendered by the world itself (:func:`.world.render`), so nothing of the
code under test enters the bound. A rival family's columns are its members linearised at
their starting amplitude, one column per free amplitude (a chip direction gives two, α per
link one per link), over a grid of its discrete and non-linear parameters (which length,
joint, link, camera; time constants); λ is the least over that grid. Instrument effects are
left out of the rivals and every rival's freedom is the nominal model's only (no rig
tolerances), so the bound can only be too generous: a strict count above it is impossible.

A second bound, :func:`guarded_power_bound`, is for naming an effect at all while keeping the
level on a rig that errs by more than it states. A test that names an effect in at most
``level`` of the effect-free worlds whose rig and thermal camera err by ``scale`` times the
rig's stated tolerances (the bench's 2× and 3× worlds) cannot detect the effect, in a world
whose errors are as stated, more often than the most powerful test of the simple hypothesis
"no effect, errors at ``scale``×" against "this effect, errors at 1×". The world's nuisances
(its rig, drawn again and again as :func:`.world.draw_scene` draws it, and the thermal camera's
errors, through the nominal model fed the readings) are close to linear in normally drawn
errors, so both hypotheses are close to normal: mean and covariance measured on ``draws`` of
the world's own nuisances at each scale, on every row of the three runs with α and a
per-series offset projected out; the likelihood ratio's power is then simulated. The null is
every scale from 1 to ``scale`` (a test must keep its level on a rig as stated too, else it
would tell the rig's size, not the effect), so the bound is the least power over scales 1,
1.5, …, ``scale``. Only the white part of the visit errors is counted, so this bound too can
only be too generous.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.stats import norm

from thermrs.bench.world.snr import Sizer, stack
from thermrs.bench.world.truth import AMPLITUDE, EFFECTS, Truth
from thermrs.bench.world.world import (
    AR_SHARE,
    CENTROID_UM,
    Scene,
    nominal_prediction,
    render,
    with_nuisances_redrawn,
)

__all__ = ["guarded_power_bound", "rival_members", "strict_power_bound"]

FloatArray = npt.NDArray[np.float64]

#: Time constants (min) a rival lag, chip drift or mount is tried at.
_TAUS_MIN = (10.0, 22.0, 50.0, 110.0, 240.0, 540.0)
_CHIP_TAUS_MIN = (10.0, 30.0, 60.0, 120.0)


def rival_members(scene: Scene, name: str) -> Iterator[list[Truth]]:
    """The members of effect family ``name`` on ``scene``'s rig: each a list of effects at
    their starting amplitude, one per free amplitude of that member (module docs).

    Examples
    --------
    >>> members = list(rival_members(scene, "joint_offset"))  # doctest: +SKIP
    """
    rig = scene.true
    links = [t for t in dict.fromkeys(rig.expansion.values()) if t != "ambient"]
    cams = [c.name for c in rig.chips]
    a0 = AMPLITUDE[name][0]
    unit = (np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    if name == "alpha_per_link":
        yield [Truth(name, a0, {"pattern": {k: float(k == link) for k in links}}) for link in links]
    elif name == "thermal_lag":
        for tau in _TAUS_MIN:
            yield [Truth(name, tau, {"ratio": 1.0})]
    elif name == "unmodelled_length":
        for ln in rig.unlisted_lengths():
            for link in links:
                yield [Truth(name, a0, {"length": ln, "temperature": link})]
    elif name == "fixture_drift":
        for cam in cams:
            for tau in _CHIP_TAUS_MIN:
                yield [
                    Truth(name, a0, {"camera": cam, "dir": u, "mount_tau_min": tau}) for u in unit
                ]
    elif name == "sensor_drift":
        for cam in cams:
            for tau in _CHIP_TAUS_MIN:
                yield [Truth(name, a0, {"camera": cam, "dir": u, "tau_min": tau}) for u in unit]
    elif name == "laser_tilt":
        yield [Truth(name, a0, {"azimuth_deg": az}) for az in (0.0, 90.0)]
    elif name == "joint_offset":
        for joint in rig.joint_names:
            for link in links:
                yield [Truth(name, a0, {"joint": joint, "temperature": link, "sign": 1.0})]
    elif name == "nonlinear_alpha":
        yield [Truth(name, a0, {"sign": 1.0})]
    else:
        raise ValueError(f"not a SPEC §6 effect: {name!r}")


def _residual_norm2(x: FloatArray, y: FloatArray) -> float:
    """‖y − x β̂‖² by least squares on unit-norm columns (SVD: the columns may be collinear)."""
    n = np.linalg.norm(x, axis=0)
    beta, *_ = np.linalg.lstsq(x / np.where(n > 0, n, 1.0), y, rcond=1e-10)
    r = y - (x / np.where(n > 0, n, 1.0)) @ beta
    return float(r @ r)


def strict_power_bound(
    scene: Scene,
    truths: tuple[Truth, ...],
    *,
    level: float = 0.05,
    rivals: tuple[str, ...] | None = None,
) -> dict[str, Any]:
    """An upper bound on the probability that a level-``level`` test rejects every other
    effect family when ``truths`` (one effect) is the world's (module docs).

    Parameters
    ----------
    scene
        The case's world.
    truths
        The injected effect, at the amplitude of the case.
    level
        The rival test's level.
    rivals
        The rival families (default: every other SPEC §6 effect).

    Returns
    -------
    dict
        ``lambda``: per rival family the least non-centrality over its members;
        ``hardest``: the rival with the least; ``power_bound``: ``Φ(√λ − z₁₋ₗₑᵥₑₗ)`` for it.

    Examples
    --------
    >>> strict_power_bound(scene, (truth,))["power_bound"]  # doctest: +SKIP
    0.31
    """
    if len(truths) != 1:
        raise ValueError("the bound is for one effect")
    sizer = Sizer(scene)
    base, series, _ = stack(render(scene, noise=False))
    d = stack(render(scene, truths, noise=False))[0] - base
    onehot = (series[:, None] == np.unique(series)[None, :]).astype(np.float64)
    fixed = np.column_stack([sizer.x_alpha, onehot])
    c = scene.campaign
    white2 = c.sigma_um**2 - (AR_SHARE * c.sigma_um) ** 2 * (scene.world == "ar1")
    white2 = max(white2, CENTROID_UM**2)
    lam: dict[str, float] = {}
    for name in rivals or tuple(e for e in EFFECTS if e != truths[0].name):
        best = np.inf
        for member in rival_members(scene, name):
            cols = [
                (stack(render(scene, (t,), noise=False))[0] - base) / t.amplitude for t in member
            ]
            best = min(best, _residual_norm2(np.column_stack([fixed, *cols]), d))
        lam[name] = best / white2
    hardest = min(lam, key=lambda k: lam[k])
    z = float(norm.ppf(1.0 - level))
    return {
        "lambda": lam,
        "hardest": hardest,
        "power_bound": float(norm.cdf(np.sqrt(lam[hardest]) - z)),
    }


def _white_variance(scene: Scene) -> float:
    """The white part of the visit errors' variance (µm²): the AR(1) pose errors left out."""
    c = scene.campaign
    white2 = c.sigma_um**2 - (AR_SHARE * c.sigma_um) ** 2 * (scene.world == "ar1")
    return float(max(white2, CENTROID_UM**2))


def _nuisance(scene: Scene) -> FloatArray:
    """What the world's rig and instruments leave over the nominal model on every row: the
    true spots without visit errors against the nominal model fed the instruments' readings."""
    truth = stack(render(scene, noise=False))[0]
    readings = render(scene)  # only the readings are used: their spots carry visit errors
    return truth - np.concatenate(nominal_prediction(scene, readings))


def _logpdf(y: FloatArray, m: FloatArray, chol: FloatArray) -> FloatArray:
    """The normal log-density of the rows of ``y`` (mean ``m``, covariance ``chol·cholᵀ``), up to
    a constant common to every covariance."""
    z = np.linalg.solve(chol, (y - m).T)
    return np.asarray(-0.5 * np.sum(z**2, axis=0) - np.sum(np.log(np.diag(chol))))


def _np_powers(
    alt: FloatArray,
    d: FloatArray,
    nulls: dict[float, FloatArray],
    *,
    white2: float,
    level: float,
    sims: int,
    rng: np.random.Generator,
) -> dict[float, float]:
    """Per scale, the simulated power of the level-``level`` likelihood-ratio test of "no
    effect, the nuisances drawn at that scale" (``nulls``: draws × directions) against "the
    effect ``d``, the nuisances ``alt``", both normal with their draws' mean and covariance
    plus the white noise ``white2``: a test that names an effect in at most ``level`` of the
    effect-free worlds at every scale is, at each, at most as powerful (Neyman–Pearson)."""
    eye = np.eye(d.size) * white2
    m1 = np.asarray(alt.mean(axis=0) + d, dtype=np.float64)
    l1 = np.asarray(np.linalg.cholesky(np.cov(alt, rowvar=False) + eye), dtype=np.float64)
    y1 = m1 + rng.standard_normal((sims, d.size)) @ l1.T
    powers = {}
    for k, zn in nulls.items():
        m0 = np.asarray(zn.mean(axis=0), dtype=np.float64)
        l0 = np.asarray(np.linalg.cholesky(np.cov(zn, rowvar=False) + eye), dtype=np.float64)
        y0 = m0 + rng.standard_normal((sims, d.size)) @ l0.T
        threshold = np.quantile(_logpdf(y0, m1, l1) - _logpdf(y0, m0, l0), 1.0 - level)
        powers[k] = float(np.mean(_logpdf(y1, m1, l1) - _logpdf(y1, m0, l0) > threshold))
    return powers


def guarded_power_bound(
    scene: Scene,
    truths: tuple[Truth, ...],
    *,
    tolerances: dict[str, float],
    scale: float,
    level: float = 0.05,
    draws: int = 400,
    sims: int = 20000,
    seed: int = 0,
) -> dict[str, Any]:
    """An upper bound on the probability that a test naming an effect in at most ``level`` of
    the effect-free worlds whose rig errs by ``scale`` × ``tolerances`` detects ``truths``
    (any number of effects) where the rig errs as stated (module docs).

    Parameters
    ----------
    scene
        The case's world (its thermal history and visit errors; its rig is drawn again).
    truths
        The injected effects, at the case's amplitudes.
    tolerances
        The rig's stated standard uncertainties (a rig file's ``[tolerances]``).
    scale
        How many times its stated tolerances the null's rig errs.
    level
        The largest share of effect-free worlds at ``scale`` in which the test names an effect.
    draws
        The world's nuisances drawn per hypothesis for their mean and covariance.
    sims
        Simulations of the likelihood ratio per hypothesis.
    seed
        Seed of the nuisance draws and the simulations.

    Returns
    -------
    dict
        ``power_bound`` and its Monte-Carlo standard error ``power_se``; ``dimension``: the
        directions the nuisances occupy (with the effect's own).

    Examples
    --------
    >>> guarded_power_bound(scene, (truth,), tolerances=rig.tolerances, scale=2.0)  # doctest: +SKIP
    {'power_bound': 0.41, ...}
    """
    rng = np.random.default_rng([seed, 45])
    sizer = Sizer(scene)
    base, series, _ = stack(render(scene, noise=False))
    d = stack(render(scene, truths, noise=False))[0] - base
    onehot = (series[:, None] == np.unique(series)[None, :]).astype(np.float64)
    fixed = np.column_stack([sizer.x_alpha, onehot])
    q, _ = np.linalg.qr(fixed / np.linalg.norm(fixed, axis=0))

    def off_fixed(x: FloatArray) -> FloatArray:
        return np.asarray(x - q @ (q.T @ x), dtype=np.float64)

    def sample(s: float) -> FloatArray:
        return np.stack(
            [
                off_fixed(_nuisance(with_nuisances_redrawn(scene, tolerances, s, rng)))
                for _ in range(draws)
            ]
        )

    scales = [float(k) for k in np.arange(1.0, scale + 1e-9, 0.5)]
    if scales[-1] != scale:
        scales.append(float(scale))
    nulls = {k: sample(k) for k in scales}
    alt = nulls[1.0]
    d = off_fixed(d)
    white2 = _white_variance(scene)
    # The directions the nuisances occupy: where their variance at the largest scale is not
    # negligible beside the white noise's (elsewhere every hypothesis is the white noise,
    # which tells nothing), and the effect's own direction.
    u, sv, _ = np.linalg.svd(nulls[scales[-1]].T, full_matrices=False)
    keep = sv**2 / draws > 1e-4 * white2
    basis, _ = np.linalg.qr(np.column_stack([u[:, keep], d]))
    powers = _np_powers(
        alt @ basis,
        d @ basis,
        {k: v @ basis for k, v in nulls.items()},
        white2=white2,
        level=level,
        sims=sims,
        rng=rng,
    )
    power = min(powers.values())
    return {
        "power_bound": power,
        "power_se": float(np.sqrt(max(power * (1 - power), 1.0 / sims) / sims)),
        "dimension": int(basis.shape[1]),
        "scale": scale,
        "by_scale": powers,
    }
