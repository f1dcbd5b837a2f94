"""The separation criterion: how surely a set of runs tells one effect from another.

For an ordered pair of rivals (A taken as the truth, B its rival) on a set of visits:

    λ_AB = min over B's families f and their non-linear parameters η of
           ‖P⊥[s, offsets, E_f(η)] · μ_A‖² / σ²

``μ_A`` is the spot every visit would show were A the truth with the parameters fitted to the
user's runs (the forward model with A, at A's fitted α); ``s`` the nominal model's α column;
``offsets`` the per-(run, camera, axis) mountings; ``E_f(η)`` B's signature columns
(:meth:`thermrs.effects.Effect.families`); ``σ`` the noise floor the diagnosis measured on the
user's runs (per visit and chip axis). λ_AB is the non-centrality of the likelihood-ratio test
of A against B under independent Gaussian noise: what remains of A's drift once B (with α and
the mountings free) has taken all it can, in units of noise variance; ``z_AB = √λ_AB`` is the
expected margin, in standard errors, by which the truth beats its rival. A measurement
separates A from B when it raises ``z`` for both orders of the pair. The residual noise of real
runs is autocorrelated, which makes ``z`` optimistic (by about √3 for the demo's runs, see
``shared/notes/diagnose-audit.md`` §4): the ranking uses it only to order candidates; the proof
(:mod:`thermrs.design.proof`) decides.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg

from thermrs.effects import Effect, Family, effect_classes, from_dict, is_instrument
from thermrs.errors import InputError, ThermrsError
from thermrs.rig import Rig
from thermrs.signatures import VisitSet

__all__ = ["Block", "Compact", "Rival", "pair_z", "rival_families", "rivals_from"]

FloatArray = npt.NDArray[np.float64]

#: Non-linear grid points of a rival family tried at most (spread over its grid).
MAX_GRID = 5


@dataclass(frozen=True)
class Rival:
    """One confounded effect with the parameters fitted to the user's runs."""

    effect: str
    params: dict[str, Any]
    alpha_per_k: float
    truth: Effect  # the effect as a simulator or forward model takes it
    holdout_rms_um: float = float("nan")

    def to_json(self) -> dict[str, Any]:
        """As ``design.json`` lists it."""
        return {
            "effect": self.effect,
            "params": self.params,
            "alpha_per_k": self.alpha_per_k,
            "simulated_as": self.truth.to_dict(),
            "holdout_rms_um": self.holdout_rms_um,
        }


def rivals_from(diagnosis: Mapping[str, Any], names: Sequence[str], rig: Rig) -> list[Rival]:
    """The named effects with the parameters of their best row in the diagnosis's ranking
    (a fitted ``weight`` out of its effect's range left at 1: a lag all of which lags, a
    length with the model's α).

    Raises
    ------
    InputError
        A name that is not an effect, or has no row in the ranking (excluded, or no family of
        it can act on these runs).
    """
    known = effect_classes()
    out = []
    for name in names:
        if name not in known:
            raise InputError(f"--between {name!r}: not an effect (known: {', '.join(known)})")
        if is_instrument(name):
            raise InputError(
                f"{name} is the thermal camera's error, not the robot's: no pose or run of the "
                "robot separates it; check the instrument (its emissivity, offset or clock) "
                "and diagnose again, or exclude it (--exclude)"
            )
        rows = [r for r in diagnosis.get("ranking", []) if r.get("effect") == name]
        if not rows:
            raise InputError(
                f"--between {name!r}: the diagnosis has no fitted parameters for it (excluded, "
                "or it cannot act on these runs)"
            )
        row = rows[0]
        alpha = float(row.get("alpha_per_k") or rig.alpha_per_k)
        cls = known[name]
        fields = set(cls.__dataclass_fields__)
        params = {k: v for k, v in row["params"].items() if k in fields}
        try:
            try:
                truth = from_dict({"name": name, **params}, rig=rig)
            except InputError:
                if "weight" not in params:
                    raise
                # A weight no such effect can have (a rival fitted against the sign of a lag
                # or of an expansion): the effect at weight 1 is what is simulated, as
                # `simulated_as` says.
                params.pop("weight")
                truth = from_dict({"name": name, **params}, rig=rig)
        except InputError as e:
            raise InputError(
                f"effect {name}: its fitted parameters do not simulate ({e})"
            ) from None
        rms = float(row.get("holdout_rms_um", float("nan")))
        out.append(Rival(name, dict(row["params"]), alpha, truth, rms))
    return out


def _basis(x: FloatArray) -> FloatArray:
    """An orthonormal basis of the columns of ``x`` (QR with pivoting on unit-norm columns;
    columns that add less than 1e-9 of their norm are dropped)."""
    n = np.linalg.norm(x, axis=0)
    x = x[:, n > 0] / n[n > 0]
    if x.shape[1] == 1:
        return np.asarray(x, dtype=np.float64)
    if x.shape[1] == 2:  # the same basis by hand (both unit columns: the first pivots)
        b = x[:, 1] - x[:, 0] * (x[:, 0] @ x[:, 1])
        b -= x[:, 0] * (x[:, 0] @ b)
        nb = float(np.linalg.norm(b))
        return x[:, :1] if nb <= 1e-9 else np.column_stack([x[:, 0], b / nb])
    q, r, _ = scipy.linalg.qr(x, mode="economic", pivoting=True)
    d = np.abs(np.diag(r))
    k = int(np.sum(d > 1e-9 * max(float(d[0]), 1e-300))) if len(d) else 0
    return np.asarray(q[:, :k], dtype=np.float64)


class Block:
    """One block of visits (the user's runs, or a candidate's) with every column the
    criterion needs, computed once: the nominal α column, the mountings, each rival's truth
    and each rival family's signature at each grid point tried."""

    def __init__(self, vs: VisitSet, rivals: Sequence[Rival]):
        self.vs = vs
        self.s = vs.alpha_column()
        self.off, _ = vs.offset_columns()
        self.mu = {
            r.effect: vs.positions(effects=[r.truth], alpha_per_k=r.alpha_per_k) for r in rivals
        }
        self.cols: dict[tuple[str, str], FloatArray | None] = {}
        self.rows = 2 * vs.n
        self._compact: dict[tuple[int, ...], Compact] = {}

    def columns(self, fam: Family, eta: dict[str, float]) -> FloatArray | None:
        """The family's signature on this block (None where it cannot act)."""
        key = _key(fam, eta)
        if key not in self.cols:
            try:
                c = fam.columns(self.vs, eta)
                self.cols[key] = c if np.all(np.isfinite(c)) else None
            except (ThermrsError, ValueError):
                self.cols[key] = None
        return self.cols[key]

    def compact(self, rivals: Sequence[Rival], families: Mapping[str, Sequence[Family]]) -> Compact:
        """This block with its rows compressed (kept, for the next candidate that reuses it)."""
        key = (*map(id, rivals), *(id(f) for r in rivals for f in families[r.effect]))
        if key not in self._compact:
            self._compact[key] = Compact(self, rivals, families)
        return self._compact[key]


def _key(fam: Family, eta: Mapping[str, float]) -> tuple[str, str]:
    return (fam.label, repr(sorted(eta.items())))


class Compact:
    """A :class:`Block` with its rows compressed: every column the criterion takes of it (α,
    mountings, each rival's truth, each signature at each grid point) replaced by the rows of
    the triangular factor ``R`` of their QR (on unit-norm columns, rescaled). ``RᵀR`` is the
    block's Gram matrix, so every projection and norm the criterion takes over a stack of
    blocks is the same, from at most as many rows per block as it has columns: a block shared by
    many candidates (the user's runs, a protocol's runs) is factored once, not once per
    candidate and grid point."""

    def __init__(
        self, block: Block, rivals: Sequence[Rival], families: Mapping[str, Sequence[Family]]
    ):
        parts: list[FloatArray] = [block.s[:, None], block.off]
        spans: dict[tuple[str, str], slice | None] = {}
        at = 1 + block.off.shape[1]
        for r in rivals:
            grid = [(f, eta) for f in families[r.effect] for eta in _grid(f)]
            own = own_family(r, families[r.effect])
            for fam, eta in grid + ([own] if own is not None else []):
                k = _key(fam, eta)
                if k in spans:
                    continue
                c = block.columns(fam, eta)
                spans[k] = None if c is None else slice(at, at + c.shape[1])
                if c is not None:
                    parts.append(c)
                    at += c.shape[1]
        mu_at = {}
        for r in rivals:
            mu_at[r.effect] = at
            parts.append(block.mu[r.effect][:, None])
            at += 1
        m = np.concatenate(parts, axis=1)
        n = np.linalg.norm(m, axis=0)
        scale = np.where(n > 0, n, 1.0)
        r_ = np.asarray(np.linalg.qr(m / scale, mode="r"), dtype=np.float64) * scale
        self.rows = r_.shape[0]
        self.s = r_[:, 0]
        self.off = r_[:, 1 : 1 + block.off.shape[1]]
        self.mu = {e: r_[:, j] for e, j in mu_at.items()}
        self._cols: dict[tuple[str, str], FloatArray | None] = {
            k: None if sl is None else r_[:, sl] for k, sl in spans.items()
        }

    def columns(self, fam: Family, eta: dict[str, float]) -> FloatArray | None:
        """The family's signature (compressed; None where it cannot act)."""
        return self._cols[_key(fam, eta)]


def rival_families(rig: Rig, vs: VisitSet, rivals: Sequence[Rival]) -> dict[str, list[Family]]:
    """Each rival effect's families on a rig (with every camera a candidate adds)."""
    classes = effect_classes()
    return {r.effect: classes[r.effect].families(rig, vs) for r in rivals}


def _grid(fam: Family) -> list[dict[str, float]]:
    grid = fam.grid
    if len(grid) > MAX_GRID:
        idx = np.unique(np.linspace(0, len(grid) - 1, MAX_GRID).round().astype(int))
        grid = [grid[i] for i in idx]
    return grid


def _stack(
    blocks: Sequence[Block | Compact], parts: Sequence[FloatArray | None], k: int
) -> FloatArray:
    rows = [
        p if p is not None else np.zeros((b.rows, k)) for b, p in zip(blocks, parts, strict=True)
    ]
    return np.concatenate(rows, axis=0)


def pair_z(
    blocks: Sequence[Block],
    rivals: Sequence[Rival],
    families: Mapping[str, Sequence[Family]],
    sigma_um: float,
) -> dict[tuple[str, str], float]:
    """``z_AB = √λ_AB`` (see the module docstring) for every ordered pair of ``rivals`` on the
    visits of ``blocks`` taken together."""
    cb = [b.compact(rivals, families) for b in blocks]
    s = np.concatenate([b.s for b in cb])
    off = scipy.linalg.block_diag(*[b.off for b in cb])
    q0 = _basis(np.column_stack([s, off]))
    mu = {}
    for a in rivals:
        m = np.concatenate([b.mu[a.effect] for b in cb])
        mu[a.effect] = m - q0 @ (q0.T @ m)
    bases: dict[str, list[FloatArray]] = {}
    for r in rivals:
        qs = []
        for fam in families[r.effect]:
            for eta in _grid(fam):
                parts = [b.columns(fam, eta) for b in cb]
                have = [p for p in parts if p is not None]
                if not have:
                    continue
                cols = _stack(cb, parts, have[0].shape[1])
                cols = cols - q0 @ (q0.T @ cols)
                if np.linalg.norm(cols) > 0:
                    qs.append(_basis(cols))
        bases[r.effect] = qs
    out: dict[tuple[str, str], float] = {}
    for a in rivals:
        for b in rivals:
            if a is b:
                continue
            left = min(
                (_left(q, mu[a.effect]) for q in bases[b.effect]),
                default=float(mu[a.effect] @ mu[a.effect]),
            )
            out[(a.effect, b.effect)] = float(np.sqrt(left) / sigma_um)
    return out


def _left(q: FloatArray, y: FloatArray) -> float:
    r = y - q @ (q.T @ y)
    return float(r @ r)


def own_family(rival: Rival, families: Sequence[Family]) -> tuple[Family, dict[str, float]] | None:
    """The family of the rival's effect the diagnosis fitted (its discrete choices equal to
    the fitted parameters) and its non-linear parameters."""
    for fam in families:
        if all(rival.params.get(k) == v for k, v in fam.choices.items()):
            keys = fam.grid[0].keys() if fam.grid else ()
            eta = {k: float(rival.params[k]) for k in keys if k in rival.params}
            if len(eta) == len(keys):
                return fam, eta
    return None


def pair_cos(
    blocks: Sequence[Block],
    rivals: Sequence[Rival],
    families: Mapping[str, Sequence[Family]],
) -> dict[tuple[str, str], float]:
    """The largest canonical correlation between the fitted families' signatures of every
    unordered pair of rivals, the nominal model (α, mountings) projected out, on the visits
    of ``blocks`` taken together (the diagnoser calls a pair confounded above 0.9)."""
    cb = [b.compact(rivals, families) for b in blocks]
    s = np.concatenate([b.s for b in cb])
    off = scipy.linalg.block_diag(*[b.off for b in cb])
    q0 = _basis(np.column_stack([s, off]))
    res: dict[str, FloatArray] = {}
    for r in rivals:
        own = own_family(r, families[r.effect])
        if own is None:
            continue
        parts = [b.columns(own[0], own[1]) for b in cb]
        have = [p for p in parts if p is not None]
        if not have:
            continue
        cols = _stack(cb, parts, have[0].shape[1])
        res[r.effect] = _basis(cols - q0 @ (q0.T @ cols))
    out: dict[tuple[str, str], float] = {}
    for i, a in enumerate(rivals):
        for b in rivals[i + 1 :]:
            qa, qb = res.get(a.effect), res.get(b.effect)
            if qa is None or qb is None or not qa.size or not qb.size:
                continue
            sv = np.linalg.svd(qa.T @ qb, compute_uv=False)
            out[(a.effect, b.effect)] = float(np.clip(sv[0], 0.0, 1.0))
    return out
