"""A bench case's world: the campaign, the true rig, the physics, the instruments and the
visit errors, drawn from one seed, and the run tables it produces.

The campaign is the issue's: three runs of ``hours`` each — training at 30 % from the room's
temperature; on another day 75 % from the room, then 10 % straight after it (a cool-down) —
one cycle every ``cycle_s`` visiting each camera once. Two nuisance worlds differ only in the
visit errors:

- ``white``: independent visit errors at the chip, N(0, σ_w) on u and v, plus 0.3 µm centroid
  noise (σ_w² + 0.3² = σ², the visit repeatability);
- ``ar1``: a pose error correlated in time — each joint an Ornstein–Uhlenbeck process with a
  correlation time drawn in [10, 30] min, sampled at the visits' times and carried through the
  true kinematics (so it moves both chips, u and v together), sized to 0.75 σ rms at the
  chips — plus white chip errors and centroid noise making up σ.

What the analysis does not model, in every case, drawn at a stated multiple (``scale``: 1, 2,
3, …) of the rig's stated ``[tolerances]`` (standard uncertainties, the diagnoser's own
assumption at 1×), each from a normal distribution of that standard deviation: the true rig
differs from the rig file (every non-zero DH length by ``length_mm``, twists and joint zeros by
``angle_deg``, each chip's centre by ``chip_mm`` per axis and its orientation by ``chip_deg``
about each axis, the laser's origin by ``laser_mm`` per axis and its direction by
``laser_deg`` about two axes); the IR camera reads each link with a common gain error
(``ir_scale``) and a per-link one (``ir_gain``, the emissivity), an offset drifting linearly
over each run by ``ir_drift_k``, at a clock off by ``ir_clock_s``. Beside these, at every
scale: the true α is the file's ±5 % (uniform; α is fitted), each link's IR offset is
constant within ±0.3 K (uniform; a constant offset is absorbed by the mountings) with 0.03 K
noise, and the room thermometer reads ±0.1 K off with 0.02 K noise.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.bench.world.geometry import (
    WorldRig,
    laser_spots,
    length_index,
    perturbed,
    tilted,
)
from thermrs.bench.world.thermal import (
    Ambient,
    Links,
    draw_ambient,
    draw_links,
    simulate_day,
)
from thermrs.bench.world.truth import Truth

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "RUNS",
    "TOLERANCE_KEYS",
    "WORLDS",
    "Campaign",
    "Scene",
    "closest_first_order_tau",
    "draw_scene",
    "measured_slopes",
    "render",
    "with_nuisances_redrawn",
]

#: The rig file's ``[tolerances]`` keys the world draws its nuisances from (module docs).
TOLERANCE_KEYS = (
    "length_mm",
    "angle_deg",
    "chip_mm",
    "chip_deg",
    "laser_mm",
    "laser_deg",
    "ir_scale",
    "ir_gain",
    "ir_drift_k",
    "ir_clock_s",
)

#: Run names, speeds, and the day each runs on (runs on one day follow straight on).
RUNS = (("train", 0.30, 0), ("hold_fast", 0.75, 1), ("hold_cool", 0.10, 1))
#: The nuisance worlds (module docs).
WORLDS = ("white", "ar1")
#: Centroid noise (µm per axis, per visit).
CENTROID_UM = 0.3
#: Share of σ from the correlated pose error in the ``ar1`` world.
AR_SHARE = 0.75
T0_NS = 1_750_000_000 * 10**9


@dataclass(frozen=True)
class Campaign:
    """Run length, cycle and visit repeatability (σ, µm per axis)."""

    hours: float = 12.0
    cycle_s: float = 600.0
    sigma_um: float = 2.0

    @property
    def day_s(self) -> float:
        """Seconds from the first day's start to the second's: whole days, at least two, and
        at least a day more than the first day's run lasts (the robot rests in between: the
        second day starts from the room's temperature, as its thermal history does)."""
        days = max(2, int(np.ceil((self.hours * 3600.0 + 86400.0) / 86400.0)))
        return days * 86400.0

    @property
    def visits(self) -> int:
        """Visits per camera per run."""
        return int(self.hours * 3600 / self.cycle_s)


@dataclass(frozen=True)
class Scene:
    """Everything a seed draws that does not depend on the injected effect."""

    nominal: WorldRig
    true: WorldRig
    campaign: Campaign
    world: str
    alpha_per_k: float
    links: Links
    days: tuple[Ambient, Ambient]
    ir_clock_s: float
    ir_gain: dict[str, float]
    ir_offset: dict[str, float]
    ir_drift: dict[tuple[str, str], float]
    room_offset: float
    corr_time_min: float
    joint_sigma_rad: float
    seed: int

    def visit_times(self, run: int, cam: int) -> FloatArray:
        """Seconds since the run's day began, of camera ``cam``'s visits in run ``run``."""
        c = self.campaign
        start = sum(c.hours * 3600 for r in RUNS[:run] if r[2] == RUNS[run][2])
        slot = c.cycle_s / (len(self.nominal.chips) + 1)
        return np.asarray(start + np.arange(c.visits) * c.cycle_s + cam * slot, dtype=np.float64)


def _jacobian(rig: WorldRig, camera: str) -> FloatArray:
    """d(u, v)/dq (µm/rad, 2 × 6) at ``camera``'s taught pose, by central differences."""
    q0 = rig.taught_rad(camera)
    h = 1e-6
    q = np.vstack([q0 + h * e for e in np.eye(6)] + [q0 - h * e for e in np.eye(6)])
    uv = laser_spots(rig, camera, q)
    return np.asarray((uv[:6] - uv[6:]).T / (2 * h), dtype=np.float64)


def draw_scene(
    nominal: WorldRig,
    campaign: Campaign,
    world: str,
    seed: int,
    *,
    tolerances: Mapping[str, float] | None = None,
    scale: float = 1.0,
) -> Scene:
    """The world of one case (module docs): the rig and the IR camera drawn from normal
    distributions at ``scale`` times the rig's stated ``tolerances`` (standard uncertainties,
    the keys of a rig file's ``[tolerances]``; default: those of the rig file ``nominal`` was
    read from, its defaults where it states none)."""
    if world not in WORLDS:
        raise ValueError(f"world {world!r}: known {', '.join(WORLDS)}")
    if tolerances is None:
        from thermrs.rig import load_rig

        tolerances = load_rig(nominal.source).tolerances
    rng = np.random.default_rng([seed, WORLDS.index(world)])
    tol = {k: scale * float(tolerances[k]) for k in TOLERANCE_KEYS}
    true = _true_rig(nominal, tol, rng)
    rois = nominal.rois or ("link",)
    common = 1.0 + rng.normal(0.0, tol["ir_scale"])
    jac = [_jacobian(true, c.name) for c in true.chips]
    per_axis = np.mean([np.sum(j**2, axis=1) for j in jac])
    alpha_per_k = nominal.alpha_per_k * rng.uniform(0.95, 1.05)
    links = draw_links(tuple(rois), rng)
    days = (draw_ambient(rng), draw_ambient(rng))
    return Scene(
        nominal=nominal,
        true=true,
        campaign=campaign,
        world=world,
        alpha_per_k=alpha_per_k,
        links=links,
        days=days,
        **_instrument_errors(tuple(rois), tol, common, rng),
        corr_time_min=rng.uniform(10.0, 30.0),
        joint_sigma_rad=AR_SHARE * campaign.sigma_um / float(np.sqrt(per_axis)),
        seed=seed,
    )


def _true_rig(nominal: WorldRig, tol: Mapping[str, float], rng: np.random.Generator) -> WorldRig:
    """The rig's geometry drawn at the standard uncertainties ``tol`` (:func:`perturbed`)."""
    return perturbed(
        nominal,
        rng,
        length_mm=tol["length_mm"],
        angle_deg=tol["angle_deg"],
        chip_mm=tol["chip_mm"],
        chip_deg=tol["chip_deg"],
        laser_mm=tol["laser_mm"],
        laser_deg=tol["laser_deg"],
    )


def _instrument_errors(
    rois: tuple[str, ...], tol: Mapping[str, float], common: float, rng: np.random.Generator
) -> dict[str, Any]:
    """The thermal camera's and the room thermometer's errors, drawn at ``tol`` (``common``:
    the IR scale shared by every ROI): the :class:`Scene` fields of that name."""
    return {
        "ir_clock_s": float(rng.normal(0.0, tol["ir_clock_s"])),
        "ir_gain": {r: common * (1 + rng.normal(0.0, tol["ir_gain"])) for r in rois},
        "ir_offset": {r: rng.uniform(-0.3, 0.3) for r in rois},
        "ir_drift": {(r, run[0]): rng.normal(0.0, tol["ir_drift_k"]) for r in rois for run in RUNS},
        "room_offset": rng.uniform(-0.1, 0.1),
    }


def with_nuisances_redrawn(
    scene: Scene, tolerances: Mapping[str, float], scale: float, rng: np.random.Generator
) -> Scene:
    """``scene`` with its rig and instruments drawn again, at ``scale`` times ``tolerances``
    (as :func:`draw_scene` draws them), its thermal history, α and visit errors kept: another
    rig of the same distribution in the same day."""
    tol = {k: scale * float(tolerances[k]) for k in TOLERANCE_KEYS}
    true = _true_rig(scene.nominal, tol, rng)
    rois = tuple(scene.ir_gain)
    common = 1.0 + rng.normal(0.0, tol["ir_scale"])
    return replace(scene, true=true, **_instrument_errors(rois, tol, common, rng))


@dataclass(frozen=True)
class Day:
    """A day's thermal history on the fine grid."""

    t_s: FloatArray
    room: FloatArray
    surface: dict[str, FloatArray]
    structure: dict[str, FloatArray]


def _days(scene: Scene, effects: tuple[Truth, ...]) -> list[Day]:
    lags: tuple[tuple[float, float], ...] = ()
    for e in effects:
        lags = lags or e.lags()
    out = []
    for day, amb in enumerate(scene.days):
        plan = [(s, scene.campaign.hours * 3600) for _, s, d in RUNS if d == day]
        t, room, surf, struct = simulate_day(scene.links, amb, plan, lags=lags)
        names = scene.links.names
        out.append(
            Day(
                t,
                room,
                dict(zip(names, surf, strict=True)),
                dict(zip(names, struct, strict=True)),
            )
        )
    return out


def _first_order(t_s: FloatArray, x: FloatArray, tau_s: float) -> FloatArray:
    """x through a first-order lag (time constant ``tau_s``), piecewise constant per step,
    starting at equilibrium."""
    y = np.empty_like(x)
    y[0] = x[0]
    a = np.exp(-np.diff(t_s) / tau_s)
    for k in range(1, x.size):
        y[k] = x[k - 1] + (y[k - 1] - x[k - 1]) * a[k - 1]
    return y


def _geometry_at(
    scene: Scene,
    rig: WorldRig,
    alpha: float,
    temps: dict[str, FloatArray],
    effects: tuple[Truth, ...],
    n: int,
) -> tuple[FloatArray, FloatArray, FloatArray | None, FloatArray]:
    """Per-sample DH lengths, a tilted laser (or None) and joint offsets (rad) under
    ``effects`` at structure temperatures ``temps`` (°C, each of length n)."""
    a = np.broadcast_to(rig.a_mm, (n, 6)).copy()
    d = np.broadcast_to(rig.d_mm, (n, 6)).copy()
    ref = rig.reference_c
    by = {e.name: e for e in effects}
    kappa = 0.0
    if "nonlinear_alpha" in by:
        kappa = by["nonlinear_alpha"].amplitude * by["nonlinear_alpha"].drawn["sign"]
    alphas: dict[str, float] = {}
    if "alpha_per_link" in by:
        spec = by["alpha_per_link"].spec(alpha)["alpha_per_k"]
        alphas = {str(k): float(v) for k, v in spec.items()}
    lengths = [(ln, t, alphas.get(t, alpha)) for ln, t in rig.expansion.items()]
    if "unmodelled_length" in by:
        u = by["unmodelled_length"]
        lengths.append((u.drawn["length"], u.drawn["temperature"], alpha * u.amplitude))
    for ln, t, al in lengths:
        dt = temps[t] - ref
        kind, i = length_index(ln)
        arr = a if kind == "a" else d
        arr[:, i] *= 1 + al * dt * (1 + kappa * dt)
    dq = np.zeros((n, 6))
    if "joint_offset" in by:
        j = by["joint_offset"]
        ji = rig.joint_names.index(j.drawn["joint"])
        dq[:, ji] = j.amplitude * j.drawn["sign"] * 1e-6 * (temps[j.drawn["temperature"]] - ref)
    laser = None
    if "laser_tilt" in by:
        lt = by["laser_tilt"]
        laser = tilted(rig.laser_direction, lt.amplitude, lt.drawn["azimuth_deg"])
    return a, d, laser, dq


def _pose_errors(scene: Scene, rng: np.random.Generator) -> dict[tuple[int, int], FloatArray]:
    """Joint-space pose error (rad, n × 6) per (run, camera): OU processes per joint, one per
    day, sampled at every visit of that day in time order (``ar1`` world; zeros otherwise)."""
    c = scene.campaign
    ncam = len(scene.nominal.chips)
    out = {(r, k): np.zeros((c.visits, 6)) for r in range(len(RUNS)) for k in range(ncam)}
    if scene.world != "ar1":
        return out
    tau = scene.corr_time_min * 60.0
    for day in (0, 1):
        keys = [(r, k) for r in range(len(RUNS)) if RUNS[r][2] == day for k in range(ncam)]
        t = np.concatenate([scene.visit_times(r, k) for r, k in keys])
        order = np.argsort(t, kind="stable")
        ts = t[order]
        x = np.empty((ts.size, 6))
        x[0] = rng.normal(0, scene.joint_sigma_rad, 6)
        rho = np.exp(-np.diff(ts) / tau)
        shocks = rng.normal(0, scene.joint_sigma_rad, (ts.size, 6))
        for i in range(1, ts.size):
            x[i] = rho[i - 1] * x[i - 1] + np.sqrt(1 - rho[i - 1] ** 2) * shocks[i]
        back = np.empty_like(x)
        back[order] = x
        for i, key in enumerate(keys):
            out[key] = back[i * c.visits : (i + 1) * c.visits]
    return out


def _chip_shift(
    effects: tuple[Truth, ...], camera: str, t: FloatArray, dd: Day, reference_c: float
) -> FloatArray:
    """(n, 2) µm the chip effects move ``camera``'s spot at visit times ``t``: a mount following
    the room through its own first-order inertia; self-heating from power-on at the day's first
    run, carried on through a run that follows straight after."""
    out = np.zeros((t.size, 2))
    for e in effects:
        if e.name not in ("fixture_drift", "sensor_drift") or e.drawn["camera"] != camera:
            continue
        if e.name == "fixture_drift":
            mount = _first_order(dd.t_s, dd.room, e.drawn["mount_tau_min"] * 60.0)
            shift = np.interp(t, dd.t_s, mount) - reference_c
        else:
            shift = 1.0 - np.exp(-t / (e.drawn["tau_min"] * 60.0))
        out += e.amplitude * shift[:, None] * e.drawn["dir"][None, :]
    return out


def render(
    scene: Scene,
    effects: tuple[Truth, ...] = (),
    *,
    noise: bool = True,
    nominal: bool = False,
    alpha_per_k: float | None = None,
) -> list[pl.DataFrame]:
    """The three run tables of ``scene`` with ``effects`` (schema of
    :func:`thermrs.bench.make_runs`).

    Parameters
    ----------
    scene
        The case's world.
    effects
        The injected effects (none: a ``none`` case).
    noise
        False: no visit errors, no centroid noise and perfect instruments (the noise-free truth
        the SNR is measured on).
    nominal
        Use the rig file's geometry instead of the true rig (the nominal model's prediction).
    alpha_per_k
        α of every listed length; default the scene's true α.
    """
    rng = np.random.default_rng([scene.seed, 7, WORLDS.index(scene.world)])
    rig = scene.nominal if nominal else scene.true
    alpha = scene.alpha_per_k if alpha_per_k is None else alpha_per_k
    days = _days(scene, effects)
    pose = _pose_errors(scene, rng)
    c = scene.campaign
    white = np.sqrt(
        max(
            c.sigma_um**2 - CENTROID_UM**2 - (AR_SHARE * c.sigma_um) ** 2 * (scene.world == "ar1"),
            0.0,
        )
    )
    tables = []
    for ri, (run, _speed, day) in enumerate(RUNS):
        dd = days[day]
        rows = []
        for ci, chip in enumerate(rig.chips):
            t = scene.visit_times(ri, ci)
            room = np.interp(t, dd.t_s, dd.room)
            temps = {k: np.interp(t, dd.t_s, v) for k, v in dd.structure.items()}
            temps["ambient"] = room
            a, d, laser, dq = _geometry_at(scene, rig, alpha, temps, effects, t.size)
            q = rig.taught_rad(chip.name)[None, :] + dq + (pose[(ri, ci)] if noise else 0.0)
            uv = laser_spots(rig, chip.name, q, a, d, laser) + _chip_shift(
                effects, chip.name, t, dd, rig.reference_c
            )
            if noise:
                uv = uv + rng.normal(0, white, uv.shape) + rng.normal(0, CENTROID_UM, uv.shape)
            obs = _instruments(scene, dd, run, t, rng, noise)
            rows.append(
                pl.DataFrame(
                    {
                        "run": [run] * t.size,
                        "camera": [chip.name] * t.size,
                        "visit": np.arange(t.size),
                        "t_ns": (T0_NS + (day * scene.campaign.day_s + t) * 1e9).astype(np.int64),
                        "u_um": uv[:, 0],
                        "v_um": uv[:, 1],
                        "drift_u_um": uv[:, 0] - uv[0, 0],
                        "drift_v_um": uv[:, 1] - uv[0, 1],
                        **obs,
                    }
                )
            )
        tables.append(pl.concat(rows))
    return tables


def _instruments(
    scene: Scene, dd: Day, run: str, t: FloatArray, rng: np.random.Generator, noise: bool
) -> dict[str, FloatArray]:
    """What the IR camera and the room thermometer report at the visits ``t``."""
    out: dict[str, FloatArray] = {}
    n = t.size
    span = max(float(t[-1] - t[0]), 1.0)
    for k, surf in dd.surface.items():
        if not noise:
            out[f"{k}_c"] = np.interp(t, dd.t_s, surf)
            continue
        tc = t - scene.ir_clock_s
        s = np.interp(tc, dd.t_s, surf)
        r = np.interp(tc, dd.t_s, dd.room)
        drift = scene.ir_drift[(k, run)] * (t - t[0]) / span
        out[f"{k}_c"] = (
            r + scene.ir_gain[k] * (s - r) + scene.ir_offset[k] + drift + rng.normal(0, 0.03, n)
        )
    room = np.interp(t, dd.t_s, dd.room)
    out["ambient_c"] = room + (scene.room_offset + rng.normal(0, 0.02, n) if noise else 0.0)
    return out


def nominal_prediction(scene: Scene, tables: list[pl.DataFrame]) -> list[FloatArray]:
    """The nominal model's spots (rig file geometry, the file's α) fed the temperatures the
    instruments of ``tables`` report, per run in the rows' order (u then v per camera, as
    :func:`.snr.stack` stacks them): what an analysis that trusts its thermometers predicts."""
    rig = scene.nominal
    out = []
    for t in tables:
        parts = []
        for cam in t["camera"].unique(maintain_order=True).to_list():
            part = t.filter(pl.col("camera") == cam)
            n = part.height
            temps = {
                c[:-2]: part[c].to_numpy().astype(np.float64)
                for c in part.columns
                if c.endswith("_c")
            }
            a, d, laser, dq = _geometry_at(scene, rig, rig.alpha_per_k, temps, (), n)
            q = rig.taught_rad(cam)[None, :] + dq
            uv = laser_spots(rig, cam, q, a, d, laser)
            parts += [uv[:, 0], uv[:, 1]]
        out.append(np.concatenate(parts))
    return out


def measured_slopes(
    scene: Scene,
    alpha_per_k: float,
    step_k: float = 20.0,
    *,
    effects: Sequence[Truth] = (),
) -> dict[tuple[str, str], FloatArray]:
    """Per (chip, link): the world's chip slope (u, v, µm) per *measured* kelvin of that
    link, at the true rig, by the world's own kinematics: the secant from every temperature at
    reference to that link ``step_k`` measured kelvin above, where the IR camera reads
    ΔT_measured = gain·ΔT_true (what a compensation law applied to measured temperatures
    must use). ``effects``: the world's effects at their true parameters (its geometric ones
    act: a link's own α, an unlisted length, a joint's zero, κ, the laser's tilt)."""
    true = scene.true
    ref = true.reference_c
    names = [*true.rois, "ambient"]
    geometric = tuple(effects)

    def spots(chip: str, temps: dict[str, float]) -> FloatArray:
        cols = {k: np.array([v]) for k, v in temps.items()}
        a, d, laser, dq = _geometry_at(scene, true, alpha_per_k, cols, geometric, 1)
        q = true.taught_rad(chip)[None, :] + dq
        return np.asarray(laser_spots(true, chip, q, a, d, laser)[0], dtype=np.float64)

    out: dict[tuple[str, str], FloatArray] = {}
    for chip in true.chips:
        base = spots(chip.name, dict.fromkeys(names, ref))
        for link in true.rois:
            temps = dict.fromkeys(names, ref)
            temps[link] = ref + step_k / scene.ir_gain[link]
            out[(chip.name, link)] = (spots(chip.name, temps) - base) / step_k
    return out


def closest_first_order_tau(scene: Scene, truth: Truth) -> float:
    """The time constant (min) of the first-order lag closest to the world's lag ``truth`` on
    ``scene``'s days, in the form SPEC §6's ``thermal_lag`` takes (the structure at
    ``T + w (lag_τ(T) - T)``, its weight ``w`` free): least squares between the structures'
    departures from their surfaces and ``w`` times the surfaces' through one first-order lag,
    every link over the whole of both days.

    A two-time-constant lag is no first-order lag; what a first-order model can estimate of it
    is this projection (its pseudo-true value), which depends on the runs' heating, and not its
    weighted mean time constant. A one-time-constant lag gives back its own.

    Examples
    --------
    >>> from thermrs.bench.world.truth import Truth
    >>> closest_first_order_tau(scene, Truth("thermal_lag", 60.0))  # doctest: +SKIP
    60.0
    """
    from scipy.optimize import minimize_scalar

    lags = truth.lags()
    if not lags:
        raise ValueError(f"{truth.name} has no lag")
    if len(lags) == 1:
        return float(lags[0][0])
    days = _days(scene, (truth,))
    y = np.concatenate([dd.structure[k] - v for dd in days for k, v in dd.surface.items()])

    def sse(log_tau: float) -> float:
        tau_s = float(np.exp(log_tau)) * 60.0
        x = np.concatenate(
            [_first_order(dd.t_s, v, tau_s) - v for dd in days for v in dd.surface.values()]
        )
        w = float(x @ y) / float(x @ x)
        return float(np.sum((y - w * x) ** 2))

    taus = [t for t, _ in lags]
    r = minimize_scalar(
        sse,
        bounds=(np.log(min(taus)), np.log(max(taus))),
        method="bounded",
        options={"xatol": 1e-4},
    )
    return float(np.exp(r.x))
