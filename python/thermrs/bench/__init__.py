"""The bench (``thermrs diagnose-bench``), beside the diagnoser it tests: the diagnoser on runs
it did not make, per nuisance world and signal-to-noise bin (issue 16).

The cases come from a second, independent world (:mod:`thermrs.bench.world`: its own
rig reader, DH kinematics and ray–plane geometry in numpy, a two-node thermal model per link,
its own version of every SPEC §6 effect, perturbed instruments and a true rig that differs from
the rig file) in two nuisance worlds (independent visit errors; AR(1) pose errors with a
correlation time of 10–30 min plus white), with each effect scaled to a target SNR: the rms it
leaves over the nominal model on the held-out runs once α and the offsets are refitted to the
noise-free truth, ÷ the visit repeatability. Each case is diagnosed blind, and (one-effect
cases) again with the true effect excluded from the library; there are also ``none`` cases and
two-effect cases. Scoring: :mod:`thermrs.bench.world.score`.

:func:`make_runs` is the earlier generator, kept for the tests and benchmarks that use it: it
shares the diagnoser's forward model, so it is no longer what the bench scores on. It makes
three run tables (training at one speed from ambient; held out: another speed from ambient on
another day, and a slow run straight after it), one SPEC §6 effect injected (or none), with
AR(1) (ρ = 0.7) plus white pose errors, an IR offset drift and noise, a 0.9 gain on the links'
rise, a 30 s clock offset, drifting ambient and 0.3 µm centroid noise.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.effects import Effect
from thermrs.errors import InputError
from thermrs.model import ForwardModel
from thermrs.rig import Rig

if TYPE_CHECKING:  # pragma: no cover - for type checkers only
    from thermrs.bench.world.cases import Case
    from thermrs.bench.world.world import Campaign

__all__ = ["make_runs", "run_bench"]

FloatArray = npt.NDArray[np.float64]

#: The paper's links (heat.rs calibration, exact through Table 4): τ (min), r0, span (K), s0.
LINKS = {
    "link2": (391.64, 0.438342, 5.030472, 0.0964029),
    "link3": (308.3, 1.602697, 6.041837, 0.1241591),
}


def _links(rig: Rig) -> dict[str, tuple[float, float, float, float]]:
    """The paper's two calibrated links, put on the rig's first two mapped temperatures (the
    paper rig's ``link2`` and ``link3``; on another rig, its own two ROIs)."""
    names = [t for t in dict.fromkeys(rig.mapped_temperatures) if t != "ambient"][:2]
    if len(names) < 2:
        raise InputError(f"rig {rig.source}: the bench needs two mapped link temperatures")
    return dict(zip(names, LINKS.values(), strict=True))


def _rise(params: tuple[float, float, float, float], speed: float) -> float:
    _, r0, span, s0 = params
    return float(r0 + span * (1.0 - np.exp(-speed / s0)))


def first_order_lag(t_s: FloatArray, x: FloatArray, tau_s: float) -> FloatArray:
    """Exact first-order lag of a piecewise-linear input (independent of the Rust one)."""
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, len(x)):
        h = t_s[k] - t_s[k - 1]
        a = np.exp(-h / tau_s)
        m = (x[k] - x[k - 1]) / h if h > 0 else 0.0
        y[k] = x[k] - m * tau_s + (y[k - 1] - x[k - 1] + m * tau_s) * a
    return y


def make_runs(
    rig: Rig,
    effect: Effect | None,
    *,
    seed: int,
    hours: float = 8.0,
    cycle_s: float = 60.0,
    perturb: bool = True,
) -> list[pl.DataFrame]:
    """Three run tables (``train``, ``hold_fast``, ``hold_cool``) of ``rig`` with ``effect``.

    The paper's calibrated links drive the rig's first two mapped temperatures.
    """
    rng = np.random.default_rng(seed)
    alpha = rig.alpha_per_k * rng.uniform(0.95, 1.05)
    plan = [  # (name, speed, start state: "ambient" or "continue", ambient slope K/h)
        ("train", 0.30, "ambient", rng.choice([-1, 1]) * rng.uniform(0.03, 0.1)),
        ("hold_fast", 0.75, "ambient", rng.choice([-1, 1]) * rng.uniform(0.03, 0.1)),
        ("hold_cool", 0.10, "continue", rng.choice([-1, 1]) * rng.uniform(0.03, 0.1)),
    ]
    lag_tau, chip, geo = _split_effect(effect)
    links = _links(rig)
    w = _World(
        rig=rig,
        rng=rng,
        model=ForwardModel(rig, alpha_per_k=alpha, effects=geo),
        links=links,
        cams=[c.name for c in rig.cameras],
        n=int(hours * 3600 / cycle_s),
        cycle_s=cycle_s,
        perturb=perturb,
        lag_tau=lag_tau,
        chip=chip,
    )
    state = {k: 0.0 for k in links}  # rise above ambient
    tables = []
    for ri, (name, speed, start, slope) in enumerate(plan):
        if start == "ambient":
            state = {k: 0.0 for k in links}
        t_fine, rise = w.surface_rise(state, speed)
        amb_fine = _AMBIENT_C + 0.5 * ri + slope * t_fine / 3600.0
        ir_off = {k: rng.uniform(-0.03, 0.03) if perturb else 0.0 for k in links}
        run = _Run(name, ri, t_fine, rise, amb_fine, ir_off)
        ar = np.zeros((len(w.cams), 6))
        rows = [w.camera_table(run, ci, ar) for ci in range(len(w.cams))]
        tables.append(pl.concat(rows))
    return tables


#: The bench's ambient at the first run's start (°C); each run starts 0.5 K warmer.
_AMBIENT_C = 23.4
#: The first run's start (ns since the epoch); runs start 30 h apart.
_T0_NS = 1_750_000_000 * 10**9


def _split_effect(effect: Effect | None) -> tuple[float | None, Effect | None, list[Effect]]:
    """The effect as the bench world applies it: a thermal lag's τ (s), an effect on a chip
    (fixture or sensor drift), or one the forward model carries (geometry)."""
    if effect is None:
        return None, None, []
    if effect.name == "thermal_lag":
        return float(effect.tau_min) * 60.0, None, []  # type: ignore[attr-defined]
    if effect.name in ("fixture_drift", "sensor_drift"):
        return None, effect, []
    return None, None, [effect]


@dataclass(frozen=True)
class _Run:
    """One run of the bench: its name and index, the surface rise per link and the ambient
    on its fine time grid (s from its start), and the thermal camera's offset drift per link."""

    name: str
    index: int
    t_fine: FloatArray
    rise: dict[str, FloatArray]
    amb_fine: FloatArray
    ir_off: dict[str, float]


@dataclass
class _World:
    """The bench's world for one call of :func:`make_runs`: the rig, its true model, the
    links' calibration, the sampling and the effect, with the random stream all draws share
    (in a fixed order: the tables depend on it)."""

    rig: Rig
    rng: np.random.Generator
    model: ForwardModel
    links: dict[str, tuple[float, float, float, float]]
    cams: list[str]
    n: int
    cycle_s: float
    perturb: bool
    lag_tau: float | None
    chip: Effect | None

    def surface_rise(
        self, state: dict[str, float], speed: float
    ) -> tuple[FloatArray, dict[str, FloatArray]]:
        """Surface rise on a fine grid (closed form per step), from ``state`` (updated to the
        run's end)."""
        t_fine = np.arange(0, self.n * self.cycle_s + self.cycle_s, 10.0)
        rise = {}
        for k, par in self.links.items():
            tau_min = par[0]
            ss = _rise(par, speed)
            rise[k] = ss + (state[k] - ss) * np.exp(-t_fine / (tau_min * 60.0))
            state[k] = float(rise[k][-1])
        return t_fine, rise

    def camera_table(self, run: _Run, ci: int, ar: FloatArray) -> pl.DataFrame:
        """The run's visits to camera ``ci``: true spots, then what the instruments report
        (``ar``: the cameras' AR(1) joint noise states)."""
        n, cam = self.n, self.cams[ci]
        slot = self.cycle_s / (len(self.cams) + 1)
        t_v: FloatArray = np.asarray(np.arange(n) * self.cycle_s + ci * slot, dtype=np.float64)
        amb_v = np.interp(t_v, run.t_fine, run.amb_fine)
        temps = self._temperatures(run, t_v, amb_v)
        sp = self.model.spots(cam, self._joints(cam, ar[ci]), temperatures=temps)
        u = sp.u_um + self.rng.normal(0, 0.3, n)
        v = sp.v_um + self.rng.normal(0, 0.3, n)
        u, v = self._on_chip(cam, u, v, t_v, amb_v)
        obs = self._observed(run, t_v, amb_v)
        return pl.DataFrame(
            {
                "run": [run.name] * n,
                "camera": [cam] * n,
                "visit": np.arange(n),
                "t_ns": (_T0_NS + (run.index * 30 * 3600 + t_v) * 1e9).astype(np.int64),
                "u_um": u,
                "v_um": v,
                "drift_u_um": u - u[0],
                "drift_v_um": v - v[0],
                **obs,
            }
        )

    def _temperatures(self, run: _Run, t_v: FloatArray, amb_v: FloatArray) -> dict[str, FloatArray]:
        """The structure's true temperatures at the visits, by the model's names (lagged
        with a thermal lag; a thermal-camera gain below 1 when perturbed)."""
        gain = 0.9 if self.perturb else 1.0
        struct = {}
        for k in self.links:
            s_fine = run.amb_fine + run.rise[k]
            if self.lag_tau is not None:
                s_fine = first_order_lag(run.t_fine, s_fine, self.lag_tau)
            s_v = np.interp(t_v, run.t_fine, s_fine)
            struct[k] = amb_v + gain * (s_v - amb_v)
        temps = {k: struct[k] for k in self.model.temperature_names if k in struct}
        if "ambient" in self.model.temperature_names:
            temps["ambient"] = amb_v
        for extra in self.model.temperature_names:
            if extra not in temps:
                temps[extra] = amb_v
        return temps

    def _joints(self, cam: str, ar: FloatArray) -> FloatArray:
        """The joints at each visit to ``cam``: its pose, perturbed by white and AR(1) noise
        (``ar``, the camera's AR state, carried from run to run within a call)."""
        n = self.n
        q0 = self.rig.camera_pose(cam).joints_rad
        if not self.perturb:
            return np.broadcast_to(q0, (n, 6)).copy()
        white = self.rng.normal(0, 1.5e-6, (n, 6))
        corr = np.empty((n, 6))
        for i in range(n):
            ar[:] = 0.7 * ar + self.rng.normal(0, 1.5e-6 * np.sqrt(1 - 0.49), 6)
            corr[i] = ar
        return np.asarray(q0[None, :] + white + corr)

    def _on_chip(
        self, cam: str, u: FloatArray, v: FloatArray, t_v: FloatArray, amb_v: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """The spot with a fixture or sensor drift of ``cam`` added."""
        chip = self.chip
        if chip is not None and chip.camera == cam:  # type: ignore[attr-defined]
            if chip.name == "fixture_drift":
                k_u, k_v = chip.um_per_k  # type: ignore[attr-defined]
                u = u + k_u * (amb_v - self.rig.reference_c)
                v = v + k_v * (amb_v - self.rig.reference_c)
            else:
                f = 1.0 - np.exp(-t_v / (chip.tau_min * 60.0))  # type: ignore[attr-defined]
                u = u + chip.um[0] * f  # type: ignore[attr-defined]
                v = v + chip.um[1] * f  # type: ignore[attr-defined]
        return u, v

    def _observed(self, run: _Run, t_v: FloatArray, amb_v: FloatArray) -> dict[str, FloatArray]:
        """What the instruments report: IR at the thermal camera's (offset) clock, its offset
        drifting, its noise; ambient with thermometer noise."""
        n = self.n
        clock_s = 30.0 if self.perturb else 0.0
        obs = {}
        for k in self.links:
            t_ir = t_v - clock_s
            drift = run.ir_off[k] * t_ir / (n * self.cycle_s)
            obs[f"{k}_c"] = (
                np.interp(t_ir, run.t_fine, run.amb_fine + run.rise[k])
                + drift
                + self.rng.normal(0, 0.03, n)
            )
        obs["ambient_c"] = amb_v + self.rng.normal(0, 0.02, n)
        return obs


def run_bench(
    rig: Rig,
    *,
    seeds: int = 1,
    effects: tuple[str, ...] | None = None,
    worlds: tuple[str, ...] = ("white", "ar1"),
    snrs: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 4.0),
    hours: float = 12.0,
    cycle_s: float = 600.0,
    sigma_um: float = 2.0,
    nulls: int = 4,
    pairs: bool = True,
    jobs: int = 1,
    first_seed: int | None = None,
    tolerance_scale: float = 1.0,
    progress: Callable[[str], object] | None = None,
) -> dict[str, Any]:
    """Run the bench (module docs); returns the JSON document ``diagnose-bench`` writes.

    Parameters
    ----------
    rig
        The rig (its file, :attr:`Rig.source`, is read again by the independent world).
    seeds
        Repetitions of the whole plan, each case with its own world.
    effects
        SPEC §6 effects to inject (default: all; empty: only the ``none`` cases).
    worlds
        Nuisance worlds: ``white`` and/or ``ar1``.
    snrs
        Target SNRs (effect rms over the nominal model ÷ visit repeatability).
    hours, cycle_s, sigma_um
        Length of each of the three runs, the cycle (one visit per camera), the visit
        repeatability (µm per chip axis).
    nulls
        ``none`` cases per seed and world.
    pairs
        Include two-effect cases.
    jobs
        Worker processes.
    first_seed
        The seed of the first case (default
        :data:`thermrs.bench.world.cases.FIRST_SEED`, the seeds the diagnoser's rules
        were chosen on; give a fresh one, ≥ 100000, for a figure about unseen worlds).
    tolerance_scale
        The worlds' rig and IR nuisances at this multiple of the rig's stated tolerances
        (1: as the rig states them, the diagnoser's null; 2, 3: a rig worse than it says).
    progress
        Called with a line per finished case.
    """
    from pathlib import Path

    from thermrs.bench.world.cases import FIRST_SEED, plan
    from thermrs.bench.world.score import score
    from thermrs.bench.world.truth import EFFECTS

    say = progress or (lambda _m: None)
    campaign = _checked_campaign(rig, worlds, snrs, hours=hours, cycle_s=cycle_s, sigma_um=sigma_um)
    cases = plan(
        rig.source,
        seeds=seeds,
        effects=EFFECTS if effects is None else tuple(effects),
        worlds=tuple(worlds),
        snrs=tuple(sorted(snrs)),
        campaign=campaign,
        nulls=nulls,
        pairs=pairs,
        first_seed=FIRST_SEED if first_seed is None else first_seed,
        tolerance_scale=tolerance_scale,
    )
    t0 = time.perf_counter()
    results: list[dict[str, Any]] = []

    def done(row: dict[str, Any]) -> None:
        results.append(row)
        got = "skipped" if "skipped" in row else row["status"]
        truth = "+".join(row["truth"]) or "none"
        say(f"{len(results)}/{len(cases)} {row['world']} {truth} SNR {row['target_snr']:g}: {got}")

    for row in _run_cases(cases, jobs=jobs):
        done(row)
    doc = score(results, tuple(sorted(snrs)), time.perf_counter() - t0)
    doc["setup"] = {
        "rig": Path(rig.source).name,
        "worlds": list(worlds),
        "snrs": sorted(snrs),
        "seeds": seeds,
        "hours": hours,
        "cycle_s": cycle_s,
        "sigma_um": sigma_um,
        "nulls": nulls,
        "jobs": jobs,
        "first_seed": FIRST_SEED if first_seed is None else first_seed,
        "tolerance_scale": tolerance_scale,
        "tolerances": dict(rig.tolerances),
        "tolerances_stated": rig.tolerances_stated,
    }
    return doc


def _checked_campaign(
    rig: Rig,
    worlds: tuple[str, ...],
    snrs: tuple[float, ...],
    *,
    hours: float,
    cycle_s: float,
    sigma_um: float,
) -> Campaign:
    """The bench's campaign, once the rig file, the worlds, the SNRs and the visits per run
    are checked.

    Raises
    ------
    InputError
        One line naming what is wrong.
    """
    from pathlib import Path

    from thermrs.bench.world.world import WORLDS, Campaign

    if not Path(rig.source).is_file():
        raise InputError(f"rig {rig.source}: the bench reads the rig file again; give a file")
    bad = sorted(set(worlds) - set(WORLDS))
    if bad:
        raise InputError(f"worlds {bad}: not nuisance worlds (known: {', '.join(WORLDS)})")
    if not snrs or min(snrs) <= 0:
        raise InputError(f"snrs {list(snrs)}: give positive target SNRs")
    campaign = Campaign(hours=hours, cycle_s=cycle_s, sigma_um=sigma_um)
    if campaign.visits < 24:
        raise InputError(f"hours {hours} at cycle {cycle_s} s: fewer than 24 visits per run")
    return campaign


def _run_cases(cases: list[Case], *, jobs: int) -> Iterator[dict[str, Any]]:
    """Each case's result row in plan order, in this process or in ``jobs`` spawned workers."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    from thermrs.bench.world.cases import run_case, worker_init

    if jobs <= 1:
        for c in cases:
            yield run_case(c)
    else:
        with ProcessPoolExecutor(jobs, get_context("spawn"), initializer=worker_init) as pool:
            yield from pool.map(run_case, cases)


def to_json(doc: dict[str, Any]) -> str:
    """The bench document as JSON text."""
    return json.dumps(doc, indent=2, default=float)
