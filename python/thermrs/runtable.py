"""Run tables: one row per visit of a run, with the temperatures at the visit's time.

:func:`run_table` joins each visit (mean centroid of its ``ok`` frames, chip µm) with the
temperatures at the visit's time: every ROI maximum and the ambient reading, interpolated
between their own samples with a shape-preserving cubic (PCHIP) and extrapolated beyond
them (a run's first visits come before its first thermal frame; holding that later,
warmer reading, or joining samples by straight lines along a curved warm-up, biases α by
a few per cent when thermal frames are sparse). A recording of several runs gives one run
table per run (:mod:`thermrs.runs`), each from its own temperature readings: they are not
measured while the robot idles between runs.

ROI maxima (SPEC §3) are maxima of noisy pixels: they read high by an amount that shrinks
as a link's hot region forms (0.05 K pixel noise: about 0.11 K at a 0.3 K rise, 0.03 K at
10 K), which compresses the measured ΔT and raises a fitted α by 1–2 %. Run tables
therefore use each ROI's de-noised peak by default (a quadratic surface fitted around the
maximum; +0.03 K at 0.3 K, 0.00 K at 10 K), and the maximum on request.

The fits (:mod:`thermrs.fit`, which re-exports these names) take run tables; files become run
tables through :func:`thermrs.runs.load_runs`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import polars as pl
from scipy.interpolate import PchipInterpolator

from thermrs.errors import InputError
from thermrs.ingest import Extraction
from thermrs.rig import Rig, as_rig

#: A rig, or the path of a rig file.
RigLike = Rig | str | os.PathLike[str]

__all__ = [
    "RUN_COLUMNS",
    "RigLike",
    "interpolate",
    "run_name",
    "run_table",
    "run_table_from",
]


def interpolate(t: np.ndarray, st: np.ndarray, sv: np.ndarray) -> np.ndarray:
    """Samples (st, sv) at t: shape-preserving piecewise cubic (PCHIP, scipy), which follows a
    first-order warm-up far better than straight lines between sparse thermal frames, and
    extrapolates smoothly beyond the ends."""
    if len(st) == 0:
        return np.full(len(t), np.nan)
    if len(st) == 1:
        return np.full(len(t), float(sv[0]))
    keep = np.concatenate([[True], np.diff(st) > 0])
    return np.asarray(PchipInterpolator(st[keep], sv[keep], extrapolate=True)(t))


#: Columns the fits need of a run table (:func:`run_table` also gives ``drift_u_um``,
#: ``drift_v_um`` and one ``<name>_c`` per temperature).
RUN_COLUMNS = ("run", "camera", "visit", "t_ns", "u_um", "v_um")


def run_table(
    ex: Extraction, rig: RigLike, *, run: str = "run", temperature: str = "peak"
) -> pl.DataFrame:
    """The run table of an extraction: one row per visit, with the temperatures at its time.

    Parameters
    ----------
    ex
        The extraction (:func:`thermrs.extract`).
    rig
        The rig it was recorded on (a :class:`~thermrs.Rig` or the path of a rig file).
    run
        The run's name (the ``run`` column).
    temperature
        ``"peak"`` (default, the de-noised ROI peak) or ``"max"`` (the ROI maximum).

    Returns
    -------
    polars.DataFrame
        See :func:`run_table_from`.

    Raises
    ------
    TypeError
        ``ex`` is not an :class:`~thermrs.Extraction` or ``rig`` not a rig.
    InputError
        ``temperature`` is neither ``"peak"`` nor ``"max"``, or the extraction holds several
        runs (one table across them would anchor every run at the first one's start; use
        :func:`thermrs.runs.load_runs`).

    Examples
    --------
    >>> import thermrs
    >>> ex = thermrs.extract("run1.mcap", thermrs.load_rig())  # doctest: +SKIP
    >>> thermrs.fit.run_table(ex, thermrs.load_rig(), run="run1").columns[:4]  # doctest: +SKIP
    ['run', 'camera', 'visit', 't_ns']
    """
    if not isinstance(ex, Extraction):
        raise TypeError(
            f"run_table takes a thermrs.Extraction, not {type(ex).__name__} "
            "(for tables use run_table_from, for a file load_run_table)"
        )
    if ex.runs.height > 1:
        # One table across runs would anchor every run's drift at the first one's start.
        raise InputError(
            f"the extraction holds {ex.runs.height} runs ({', '.join(ex.runs['run'])}): one "
            "run table per run, e.g. thermrs.runs.load_runs(path, rig).tables"
        )
    return run_table_from(ex.visits, ex.temperatures, rig, run=run, temperature=temperature)


def run_table_from(
    visits: pl.DataFrame,
    temperatures: pl.DataFrame,
    rig: RigLike,
    *,
    run: str = "run",
    temperature: str = "peak",
) -> pl.DataFrame:
    """The run table: one row per visit with ``ok`` frames.

    Parameters
    ----------
    visits, temperatures
        The recording's visits and temperatures tables (:class:`thermrs.Extraction`, or the
        ``.visits.parquet`` and ``.temperatures.parquet`` files ``thermrs extract`` writes).
    rig
        The rig it was recorded on.
    run
        The run's name (the ``run`` column).
    temperature
        Which ROI reading to use: ``"peak"`` (default; the de-noised peak, which does not read
        high the way the maximum of noisy pixels does) or ``"max"`` (the ROI maximum of SPEC §3,
        the paper's reading).

    Returns
    -------
    polars.DataFrame
        ``run``, ``camera``, ``visit``, ``t_ns``, ``u_um``, ``v_um``, ``drift_u_um``,
        ``drift_v_um`` and one ``<name>_c`` column per ROI and ``ambient`` (°C at the visit
        time, PCHIP interpolation between the readings, see the module docs).

    Raises
    ------
    InputError
        ``temperature`` is neither ``"peak"`` nor ``"max"``, or a table lacks its columns.
    TypeError
        ``visits`` or ``temperatures`` is not a polars DataFrame.

    Examples
    --------
    >>> import polars as pl, thermrs
    >>> v = pl.read_parquet("run1.visits.parquet")  # doctest: +SKIP
    >>> t = pl.read_parquet("run1.temperatures.parquet")  # doctest: +SKIP
    >>> thermrs.fit.run_table_from(v, t, thermrs.load_rig(), run="run1")  # doctest: +SKIP
    """
    for name, df in (("visits", visits), ("temperatures", temperatures)):
        if not isinstance(df, pl.DataFrame):
            raise TypeError(f"{name} must be a polars DataFrame, not {type(df).__name__}")
    as_rig(rig)
    need: dict[str, tuple[str, ...]] = {
        "visits": ("camera", "t_ns", "n_ok", "u_um", "v_um", "drift_u_um", "drift_v_um"),
        "temperatures": ("t_ns", "name"),
    }
    for name, df in (("visits", visits), ("temperatures", temperatures)):
        lacking = [c for c in need[name] if c not in df.columns]
        if lacking:
            raise InputError(f"the {name} table has no column(s) {lacking}")
    if temperature not in ("peak", "max"):
        raise InputError(f"temperature must be 'peak' or 'max', got {temperature!r}")
    column = "peak_c" if temperature == "peak" else "temperature_c"
    v = visits.filter(pl.col("n_ok") > 0).sort("camera", "t_ns")
    t = v["t_ns"].to_numpy().astype(np.float64)
    cols: dict[str, np.ndarray] = {}
    temps = temperatures
    if column not in temps.columns:  # tables extracted before the peak existed
        column = "temperature_c"
    for name in sorted(set(temps["name"].to_list())):
        s = temps.filter(pl.col("name") == name).sort("t_ns")
        st = s["t_ns"].to_numpy().astype(np.float64)
        sv = s[column].to_numpy()
        cols[f"{name}_c"] = interpolate(t, st, sv)
    return v.select(
        pl.lit(run).alias("run"),
        "camera",
        "visit",
        "t_ns",
        "u_um",
        "v_um",
        "drift_u_um",
        "drift_v_um",
    ).with_columns(**{k: pl.Series(k, a) for k, a in cols.items()})


def run_name(path: str | os.PathLike[str]) -> str:
    """The run name :func:`load_run_table` gives a file by default: its name without
    ``.mcap``, or without ``[.visits|.temperatures|.joints].parquet``."""
    name = Path(path).name
    if name.endswith(".parquet"):
        stem = name[: -len(".parquet")]
        for part in (".visits", ".temperatures", ".joints"):
            if stem.endswith(part):
                return stem[: -len(part)]
        return stem
    return name[: -len(".mcap")] if name.endswith(".mcap") else Path(name).stem
