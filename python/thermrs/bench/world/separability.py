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
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.stats import norm

from thermrs.bench.world.snr import Sizer, stack
from thermrs.bench.world.truth import AMPLITUDE, EFFECTS, Truth
from thermrs.bench.world.world import AR_SHARE, CENTROID_UM, Scene, render

__all__ = ["rival_members", "strict_power_bound"]

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
