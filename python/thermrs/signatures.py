"""Visits of several runs, ready for the forward model with effects: the spot every visit
should show, and the signature columns the diagnoser fits.

A :class:`VisitSet` holds the run tables' visits (sorted by run, camera and time) with their
temperatures, and evaluates the forward model at the camera's taught pose with any SPEC §6
effects (:mod:`thermrs.effects`): the structure's lag behind the surface (over each run's visit
series of a camera), the expanded geometry, and the chip shifts (ambient, time since the run
began). Positions are returned as one vector of length 2n: every visit's u (µm), then its v.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import polars as pl

import thermrs._native as _native
from thermrs.effects import EFFECT_NAMES, AlphaPerLink, Effect
from thermrs.errors import InputError
from thermrs.rig import Camera, Rig

__all__ = ["CHAIN_GAP_S", "VisitSet"]

#: Longest pause (s) between two runs of a camera across which a stateful effect's state is
#: carried (an idle robot between runs of one session); after a longer pause, or between runs
#: that overlap in time (two clocks), each run starts from equilibrium.
CHAIN_GAP_S = 3600.0

FloatArray = npt.NDArray[np.float64]


class VisitSet:
    """The visits of run tables, with the forward model at hand.

    Parameters
    ----------
    tables
        Run tables (:func:`thermrs.fit.run_table`), any number of runs; rows without a finite
        u or v are dropped.
    rig
        The rig they were recorded on.
    shift_drivers
        Placebo: every temperature series and the time since the run began are shifted
        circularly by half of each (run, camera) series, which keeps their smoothness but
        breaks their alignment with the measured drift.
    """

    def __init__(self, tables: Sequence[pl.DataFrame], rig: Rig, *, shift_drivers: bool = False):
        if isinstance(tables, pl.DataFrame):
            tables = [tables]
        if not tables:
            raise InputError("no run tables given")
        table = pl.concat(list(tables), how="diagonal_relaxed").sort("run", "camera", "t_ns")
        table = table.filter(pl.col("u_um").is_finite() & pl.col("v_um").is_finite())
        if table.height == 0:
            raise InputError("the runs have no visits with a spot")
        self.rig = rig
        self.table = table
        self.n = table.height
        self.alpha0 = rig.alpha_per_k
        self.run = table["run"].to_numpy().astype(str)
        self.camera = table["camera"].to_numpy().astype(str)
        t_ns = table["t_ns"].to_numpy()
        self.t_ns = t_ns
        self.t_s = (t_ns - t_ns.min()).astype(np.float64) / 1e9
        self.y = np.concatenate([table["u_um"].to_numpy(), table["v_um"].to_numpy()])
        self.groups: list[np.ndarray] = []
        key = np.char.add(np.char.add(self.run, "\0"), self.camera)
        for k in dict.fromkeys(key.tolist()):
            self.groups.append(np.flatnonzero(key == k))
        starts = {r: self.t_s[self.run == r].min() for r in np.unique(self.run)}
        self.t_since_start = np.array([self.t_s[i] - starts[r] for i, r in enumerate(self.run)])
        self.temps: dict[str, FloatArray] = {}
        for c in table.columns:
            if c.endswith("_c") and table[c].dtype.is_numeric():
                v = table[c].to_numpy().astype(np.float64)
                if np.all(np.isfinite(v)):
                    self.temps[c[:-2]] = v
        # Chains: per camera, runs that follow one another (the next starts after the last
        # ends, within CHAIN_GAP_S): a stateful effect (the structure's lag, a chip's
        # self-heating) carries its state from one into the next instead of restarting.
        self.chains: list[list[np.ndarray]] = []
        by_cam: dict[str, list[np.ndarray]] = {}
        for g in self.groups:
            by_cam.setdefault(str(self.camera[g[0]]), []).append(g)
        self.t_since_chain = self.t_since_start.copy()
        for gs in by_cam.values():
            gs = sorted(gs, key=lambda g: float(self.t_s[g[0]]))
            chain = [gs[0]]
            for g in gs[1:]:
                gap = float(self.t_s[g[0]] - self.t_s[chain[-1][-1]])
                if 0.0 <= gap <= CHAIN_GAP_S:
                    chain.append(g)
                else:
                    self.chains.append(chain)
                    chain = [g]
            self.chains.append(chain)
        for chain in self.chains:
            t0 = self.t_s[chain[0][0]] - self.t_since_start[chain[0][0]]
            for g in chain:
                self.t_since_chain[g] = self.t_s[g] - t0
        self.shifted = shift_drivers
        if shift_drivers:
            for name in self.temps:
                self.temps[name] = self._shift(self.temps[name])
            self.t_since_start = self._shift(self.t_since_start)
            self.t_since_chain = self._shift(self.t_since_chain)
        self._cache: dict[str, FloatArray] = {}
        self._geometry: dict[int, tuple[Camera, FloatArray]] = {}
        self._temps_by_group: dict[tuple[str, int], FloatArray] = {}

    def replaced(
        self, *, rig: Rig | None = None, temps: dict[str, FloatArray] | None = None
    ) -> VisitSet:
        """These visits on another rig or with other temperatures (nothing else recomputed;
        the forward model's inputs kept per group are dropped with them)."""
        out = copy.copy(self)
        if rig is not None:
            out.rig = rig
        if temps is not None:
            out.temps = temps
        out._cache = {}
        out._geometry = {}
        out._temps_by_group = {}
        return out

    def _shift(self, a: FloatArray) -> FloatArray:
        out = a.copy()
        for g in self.groups:
            out[g] = np.roll(a[g], len(g) // 2)
        return out

    def has(self, name: str) -> bool:
        """Whether every visit has the temperature ``name`` (a ROI or ``ambient``)."""
        return name in self.temps

    def positions(
        self, *, effects: Sequence[Effect] = (), alpha_per_k: float | None = None
    ) -> FloatArray:
        """Every visit's spot (u then v, µm) at the camera's taught pose under ``effects``.

        Raises
        ------
        InputError
            An effect needs a temperature the runs do not carry.
        """
        alpha = self.alpha0 if alpha_per_k is None else alpha_per_k
        dicts = [e.to_dict() for e in effects]
        key = repr((alpha, dicts))
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        instruments = [e for e in effects if getattr(e, "instrument", False)]
        if instruments:
            # An instrument's error is in the readings: the model sees them corrected.
            temps = dict(self.temps)
            for e in instruments:
                temps = e.corrected(temps, self, self.rig.reference_c)  # type: ignore[attr-defined]
            rest = [e for e in effects if not getattr(e, "instrument", False)]
            got = self.replaced(temps=temps).positions(effects=rest, alpha_per_k=alpha)
            if len(self._cache) < 256:
                self._cache[key] = got
            return got
        # The native model straight from the effects' SPEC §6 dicts: it checks them against
        # the rig as :class:`thermrs.model.ForwardModel` does, without a second round trip.
        native = _native.ForwardModel(
            self.rig._native,
            alpha_per_k=alpha,
            reference_c=None,
            effects_json=json.dumps([d for d in dicts if d["name"] in EFFECT_NAMES]),
        )
        names = native.temperature_names()
        missing = [n for n in names if n not in self.temps]
        if missing:
            raise InputError(f"the runs carry no {missing} temperature the model needs")
        lag = native.has_lag()
        chips = native.shifts_chips()
        u = np.empty(self.n)
        v = np.empty(self.n)
        lagged: dict[str, FloatArray] = {}
        if lag:
            for n in names:
                if n == "ambient":
                    continue
                out = np.empty(self.n)
                for chain in self.chains:
                    idx = np.concatenate(chain)
                    out[idx] = native.structure_temperatures(
                        np.ascontiguousarray(self.t_s[idx]),
                        np.ascontiguousarray(self.temps[n][idx]),
                    )
                lagged[n] = out
        mounts = self._mount_temperatures(native) if chips else {}
        for j, g in enumerate(self.groups):
            chip, q = self._group_geometry(j)
            cam = chip.name
            cols = [lagged[n][g] if n in lagged else self._group_temperature(n, j) for n in names]
            s = native.spots(cam, q, [np.ascontiguousarray(c) for c in cols], None)
            su, sv = chip.px_to_um(s[:, 0], s[:, 1])
            if chips:
                amb = self.temps.get("ambient")
                a = (
                    self._group_temperature("ambient", j)
                    if amb is not None
                    else np.full(len(g), self.rig.reference_c)
                )
                m = mounts.get(cam)
                d = native.chip_shifts(
                    cam,
                    a,
                    np.ascontiguousarray(self.t_since_chain[g]),
                    None if m is None else np.ascontiguousarray(m[g]),
                )
                su = su + d[:, 0]
                sv = sv + d[:, 1]
            u[g] = su
            v[g] = sv
        out = np.concatenate([u, v])
        if len(self._cache) < 256:
            self._cache[key] = out
        return out

    def _mount_temperatures(self, native: _native.ForwardModel) -> dict[str, FloatArray]:
        """Per camera whose mount lags the room (``fixture_drift``'s ``mount_tau_min``), the
        ambient as its mount sees it at every visit, lagged along each chain of runs."""
        amb = self.temps.get("ambient")
        out: dict[str, FloatArray] = {}
        if amb is None:
            return out
        for cam in dict.fromkeys(str(c) for c in self.camera):
            if not native.has_mount_lag(cam):
                continue
            m = np.empty(self.n)
            for chain in self.chains:
                idx = np.concatenate(chain)
                m[idx] = native.mount_temperatures(
                    cam, np.ascontiguousarray(self.t_s[idx]), np.ascontiguousarray(amb[idx])
                )
            out[cam] = m
        return out

    def _group_geometry(self, j: int) -> tuple[Camera, FloatArray]:
        """Group ``j``'s chip and its taught joints per visit (contiguous): what
        :meth:`positions` hands the native model."""
        hit = self._geometry.get(j)
        if hit is None:
            g = self.groups[j]
            chip = self.rig.camera(str(self.camera[g[0]]))
            q = np.ascontiguousarray(
                np.broadcast_to(
                    np.asarray(self.rig.camera_pose(chip.name).joints_rad), (len(g), 6)
                ),
                dtype=np.float64,
            )
            hit = (chip, q)
            self._geometry[j] = hit
        return hit

    def _group_temperature(self, name: str, j: int) -> FloatArray:
        """The temperature ``name`` over group ``j``'s visits (contiguous, kept)."""
        key = (name, j)
        hit = self._temps_by_group.get(key)
        if hit is None:
            hit = np.ascontiguousarray(self.temps[name][self.groups[j]], dtype=np.float64)
            self._temps_by_group[key] = hit
        return hit

    def alpha_column(self, *, only: str | None = None) -> FloatArray:
        """The spot's displacement per unit α from the reference temperature (u then v), from
        every mapped temperature, or from ``only`` that one."""
        cold = self.positions(alpha_per_k=0.0)
        if only is None:
            hot = self.positions()
        else:
            per = {t: (self.alpha0 if t == only else 0.0) for t in self.rig.mapped_temperatures}
            hot = self.positions(effects=[AlphaPerLink(alpha_per_k=per)])
        return (hot - cold) / self.alpha0

    def offset_columns(self) -> tuple[FloatArray, list[str]]:
        """Indicator columns (2n, 2g) of every (run, camera, axis): the unknown mounting."""
        x = np.zeros((2 * self.n, 2 * len(self.groups)))
        names = []
        for j, g in enumerate(self.groups):
            x[g, 2 * j] = 1.0
            x[self.n + g, 2 * j + 1] = 1.0
            label = f"{self.run[g[0]]}/{self.camera[g[0]]}"
            names += [f"{label}/u", f"{label}/v"]
        return x, names

    @property
    def axis(self) -> npt.NDArray[np.str_]:
        """``u`` for the first n rows of a 2n vector, ``v`` for the rest."""
        return np.array(["u"] * self.n + ["v"] * self.n)
