"""ISO 9283-style pose figures, 2-D in the chip plane (issue #5, "ISO 9283-style figures").

ISO 9283:1998 rates a robot's pose repeatability (RP) and the drift of its pose accuracy (dAP)
and repeatability (dRP) from the positions it attains in repeated cycles. The figures here are
*ISO 9283-style, 2-D in the chip plane*, not the standard's 3-D figures:

- a camera's chip sees only the two axes of its plane, so every position is the spot's mean
  position of one visit on one chip, ``P_j = (u_j, v_j)`` in chip micrometres (SPEC §4);
- the commanded position is unknown (each camera's mounting offset is, SPEC §4), so accuracy
  is taken relative to the *cold barycentre*, the barycentre of the run's first window of
  visits. ``dAP`` is therefore the distance between two barycentres, ``|bary_t − bary_cold|``,
  where the standard takes the difference of two accuracies measured against the command
  (``|AP_1 − AP_t|``, which the triangle inequality bounds by this distance).

Per window of ``n`` visits of one camera (ISO 9283 §7.2.2, with the sample standard deviation):

```text
bary = (ū, v̄) = mean of P_j,   l_j = |P_j − bary|,   l̄ = mean of l_j,
S_l = sqrt(Σ (l_j − l̄)² / (n − 1)),   RP = l̄ + 3·S_l.
```

Windows are consecutive, non-overlapping runs of ``window`` visits per camera and run, from the
camera's first visit; a trailing remainder shorter than ``window`` forms no window (every RP
comes from the same number of visits), but it counts for the settling time. Per window
``dap_um = |bary − bary of the first (cold) window|`` and ``drp_um = RP − RP of the first
window`` (signed: positive means the repeatability got worse).

Settling time (``settle_min``)
    The barycentres of a *rolling* window of ``window`` consecutive visits are compared with the
    final barycentre (that of the last non-overlapping window). The run has settled at the
    first rolling window from which every later rolling window stays within ``tolerance_um``
    of it; ``settle_min`` is the time from the run's first visit (any camera) to that window's
    mean visit time (its centre), or 0 when even the first window is within tolerance. It is
    null when the run is too short (fewer than two windows) or when the barycentre only comes
    within tolerance in a window that shares visits with the final window (a window agrees with
    itself: no evidence of settling).

Example
-------
>>> import numpy as np
>>> from thermrs.iso9283 import iso9283, rp
>>> angle = np.deg2rad([10.0, 100.0, 190.0, 280.0])  # four points on a circle of 2 µm
>>> bary_u, bary_v, l_mean, s_l, rp_um = rp(2.0 * np.cos(angle), 2.0 * np.sin(angle))
>>> round(l_mean, 9), round(s_l, 9), round(rp_um, 9)
(2.0, 0.0, 2.0)
>>> figures = iso9283(table, window=10, tolerance_um=1.0)  # doctest: +SKIP
>>> figures.summary.select("camera", "rp_cold_um", "dap_um", "settle_min")  # doctest: +SKIP
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.errors import InputError

__all__ = ["LABEL", "SUMMARY_SCHEMA", "WINDOW_SCHEMA", "Iso9283", "iso9283", "rp"]

FloatArray = npt.NDArray[np.float64]

#: What these figures are (and are not).
LABEL = "ISO 9283-style, 2-D in the chip plane (accuracy relative to the cold barycentre)"

#: Columns of :attr:`Iso9283.windows`.
WINDOW_SCHEMA: dict[str, Any] = {
    "run": pl.String,
    "camera": pl.String,
    "window": pl.Int64,
    "t_start_ns": pl.Int64,
    "t_end_ns": pl.Int64,
    "n": pl.Int64,
    "bary_u_um": pl.Float64,
    "bary_v_um": pl.Float64,
    "l_mean_um": pl.Float64,
    "s_l_um": pl.Float64,
    "rp_um": pl.Float64,
    "dap_um": pl.Float64,
    "drp_um": pl.Float64,
}

#: Columns of :attr:`Iso9283.summary`.
SUMMARY_SCHEMA: dict[str, Any] = {
    "run": pl.String,
    "camera": pl.String,
    "rp_cold_um": pl.Float64,
    "rp_warm_um": pl.Float64,
    "dap_um": pl.Float64,
    "drp_um": pl.Float64,
    "settle_min": pl.Float64,
    "n_visits": pl.Int64,
    "n_windows": pl.Int64,
    "note": pl.String,
}

REQUIRED = ("run", "camera", "t_ns", "u_um", "v_um")


@dataclass(frozen=True)
class Iso9283:
    """ISO 9283-style figures of a run table (see the module docstring).

    Attributes
    ----------
    windows
        One row per run, camera and window: columns :data:`WINDOW_SCHEMA`.
    summary
        One row per run and camera: ``rp_cold_um`` (first window), ``rp_warm_um`` (last
        window), ``dap_um`` and ``drp_um`` (the last window's), ``settle_min``, ``n_visits``,
        ``n_windows`` and a ``note`` where figures are null (no window: all null; one window:
        only ``rp_cold_um``; not settled: ``settle_min``).
    window
        Visits per window.
    tolerance_um
        The settling tolerance.
    """

    windows: pl.DataFrame
    summary: pl.DataFrame
    window: int
    tolerance_um: float

    def to_json(self) -> dict[str, object]:
        """A JSON-ready document (NaN as null)."""
        return {
            "method": LABEL,
            "window": self.window,
            "tolerance_um": self.tolerance_um,
            "summary": [_clean(r) for r in self.summary.to_dicts()],
            "windows": [_clean(r) for r in self.windows.to_dicts()],
        }


def _clean(row: dict[str, Any]) -> dict[str, Any]:
    return {k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in row.items()}


def rp(u_um: npt.ArrayLike, v_um: npt.ArrayLike) -> tuple[float, float, float, float, float]:
    """ISO 9283 pose repeatability of a set of 2-D positions.

    Parameters
    ----------
    u_um, v_um
        The attained positions (at least 2).

    Returns
    -------
    tuple
        ``(bary_u, bary_v, l_mean, s_l, rp)``: barycentre, mean distance from it, the sample
        standard deviation of the distances and ``RP = l_mean + 3·s_l``.

    Raises
    ------
    InputError
        Fewer than 2 positions, unequal lengths or non-finite values.

    Examples
    --------
    Four positions on the corners of a 2 µm square: every one √2 µm from the barycentre.

    >>> from thermrs.iso9283 import rp
    >>> bu, bv, l_mean, s_l, r = rp([1, -1, 1, -1], [1, 1, -1, -1])
    >>> (bu, bv, round(l_mean, 6), round(s_l, 6), round(r, 6))
    (0.0, 0.0, 1.414214, 0.0, 1.414214)
    """
    u = np.asarray(u_um, dtype=np.float64)
    v = np.asarray(v_um, dtype=np.float64)
    if u.ndim != 1 or u.shape != v.shape:
        raise InputError("rp: u and v must be 1-D of equal length")
    if len(u) < 2:
        raise InputError(f"rp: {len(u)} positions, need at least 2")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(v))):
        raise InputError("rp: positions must be finite")
    bu, bv = float(np.mean(u)), float(np.mean(v))
    dist = np.hypot(u - bu, v - bv)
    l_mean = float(np.mean(dist))
    s_l = float(np.std(dist, ddof=1))
    return bu, bv, l_mean, s_l, l_mean + 3.0 * s_l


def _validate(table: pl.DataFrame, window: object, tolerance_um: object) -> None:
    if isinstance(window, bool) or not isinstance(window, int | np.integer) or window < 3:
        raise InputError(f"window must be an integer ≥ 3 visits, got {window!r}")
    if (
        isinstance(tolerance_um, bool)
        or not isinstance(tolerance_um, int | float | np.floating | np.integer)
        or not (math.isfinite(float(tolerance_um)) and float(tolerance_um) > 0)
    ):
        raise InputError(f"tolerance_um must be a finite number > 0, got {tolerance_um!r}")
    missing = [c for c in REQUIRED if c not in table.columns]
    if missing:
        raise InputError(f"the run table has no column(s) {missing} (needs {list(REQUIRED)})")


def _settle(
    t_ns: npt.NDArray[np.int64],
    u: FloatArray,
    v: FloatArray,
    window: int,
    n_windows: int,
    final: tuple[float, float],
    tolerance_um: float,
    t_run0_ns: int,
) -> float | None:
    """Minutes from the run's first visit until the rolling barycentre stays settled (module
    docstring), or None."""
    if n_windows < 2:
        return None
    kernel = np.ones(window) / window
    ru = np.convolve(u, kernel, mode="valid")
    rv = np.convolve(v, kernel, mode="valid")
    rel = (t_ns - t_ns[0]).astype(np.float64)
    centre = np.convolve(rel, kernel, mode="valid")
    out = np.flatnonzero(np.hypot(ru - final[0], rv - final[1]) > tolerance_um)
    k = 0 if len(out) == 0 else int(out[-1]) + 1
    # The rolling window at k must end before the final window begins.
    if k + window > (n_windows - 1) * window:
        return None
    if k == 0:
        return 0.0
    return float((centre[k] + float(t_ns[0] - t_run0_ns)) / 60e9)


def iso9283(table: pl.DataFrame, *, window: int = 10, tolerance_um: float = 1.0) -> Iso9283:
    """ISO 9283-style figures, 2-D in the chip plane, of a run table.

    Parameters
    ----------
    table
        A run table (:func:`thermrs.fit.run_table`): ``run``, ``camera``, ``t_ns``, ``u_um``,
        ``v_um`` per visit; one or several runs. Visits without a position are left out.
    window
        Visits per window (≥ 3; default 10).
    tolerance_um
        How close (µm) the rolling barycentre must stay to the final one to count as settled.

    Returns
    -------
    Iso9283
        The per-window figures and the per-run-and-camera summary. A camera with fewer visits
        than one window has a summary row with null figures and a note.

    Raises
    ------
    InputError
        ``window`` < 3 or not an integer, ``tolerance_um`` not > 0, a required column missing,
        or no visit with a position in the table.

    Examples
    --------
    >>> import thermrs
    >>> table, _ = thermrs.fit.load_run_table("run1.parquet", thermrs.load_rig())  # doctest: +SKIP
    >>> iso = thermrs.iso9283.iso9283(table, window=10, tolerance_um=1.0)  # doctest: +SKIP
    >>> iso.summary.select("camera", "rp_cold_um", "rp_warm_um", "dap_um")  # doctest: +SKIP
    """
    _validate(table, window, tolerance_um)
    w = int(window)
    tol = float(tolerance_um)
    t = table.select(
        pl.col("run").cast(pl.String),
        pl.col("camera").cast(pl.String),
        pl.col("t_ns").cast(pl.Int64),
        pl.col("u_um").cast(pl.Float64).fill_nan(None),
        pl.col("v_um").cast(pl.Float64).fill_nan(None),
    ).drop_nulls()
    if t.height == 0:
        raise InputError("the run table has no visit with a position (u_um, v_um)")
    windows: list[dict[str, object]] = []
    summary: list[dict[str, object]] = []
    # Runs in time order (as the report's figures and Table 4 show them), not by name.
    chronological = t.group_by("run").agg(pl.col("t_ns").min()).sort("t_ns", "run")["run"]
    for run in chronological.to_list():
        tr = t.filter(pl.col("run") == run).sort("t_ns")
        t_run0 = int(tr["t_ns"][0])
        for cam in sorted(set(tr["camera"].to_list())):
            rows, row = _camera_figures(tr.filter(pl.col("camera") == cam), w, tol, t_run0)
            windows += rows
            summary.append(row)
    return Iso9283(
        windows=pl.DataFrame(windows, schema=WINDOW_SCHEMA),
        summary=pl.DataFrame(summary, schema=SUMMARY_SCHEMA),
        window=w,
        tolerance_um=tol,
    )


def _camera_figures(
    tc: pl.DataFrame, w: int, tol: float, t_run0: int
) -> tuple[list[dict[str, object]], dict[str, object]]:
    """One camera's visits in one run (``tc``, in time order): its windows' rows and its
    summary row (:func:`iso9283`); ``t_run0`` is the run's first visit, any camera."""
    t_ns = tc["t_ns"].to_numpy().astype(np.int64)
    u = tc["u_um"].to_numpy().astype(np.float64)
    v = tc["v_um"].to_numpy().astype(np.float64)
    run, cam = str(tc["run"][0]), str(tc["camera"][0])
    n = len(t_ns)
    nw = n // w
    row: dict[str, object] = dict.fromkeys(SUMMARY_SCHEMA)
    row |= {"run": run, "camera": cam, "n_visits": n, "n_windows": nw}
    if nw == 0:
        row["note"] = f"{n} visits, fewer than one window of {w}"
        return [], row
    figs = [rp(u[i * w : (i + 1) * w], v[i * w : (i + 1) * w]) for i in range(nw)]
    cold = figs[0]
    windows: list[dict[str, object]] = []
    for i, (bu, bv, lm, sl, r) in enumerate(figs):
        windows.append(
            {
                "run": run,
                "camera": cam,
                "window": i,
                "t_start_ns": int(t_ns[i * w]),
                "t_end_ns": int(t_ns[(i + 1) * w - 1]),
                "n": w,
                "bary_u_um": bu,
                "bary_v_um": bv,
                "l_mean_um": lm,
                "s_l_um": sl,
                "rp_um": r,
                "dap_um": math.hypot(bu - cold[0], bv - cold[1]),
                "drp_um": r - cold[4],
            }
        )
    row["rp_cold_um"] = cold[4]
    if nw < 2:
        row["note"] = f"{n} visits, one window of {w}: no warm window, drift or settling"
        return windows, row
    last = figs[-1]
    row |= {
        "rp_warm_um": last[4],
        "dap_um": math.hypot(last[0] - cold[0], last[1] - cold[1]),
        "drp_um": last[4] - cold[4],
        "settle_min": _settle(t_ns, u, v, w, nw, (last[0], last[1]), tol, t_run0),
    }
    if row["settle_min"] is None:
        row["note"] = (
            f"not settled: the barycentre is not within {tol:g} µm of the final one "
            "before the final window"
        )
    return windows, row
