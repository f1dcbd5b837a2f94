"""``thermrs watch``: a run followed while the robot records it — the drift so far, the drift
to come with its band, when it leaves a tolerance, and (with training runs) a sequential
diagnosis that says when the answer is in.

:func:`watch` is a generator of :class:`WatchUpdate`: each update reads only the bytes the
recorder added since the last (:class:`thermrs.follow.Follower`), and analyses the run so far
(the recording's last run: the one being recorded). It ends by itself when the recording is
closed (an MCAP footer written; a bag's ``metadata.yaml`` complete), leaving ``out`` as
``thermrs extract -o`` would, or at ``until``. Ctrl-C leaves the tables so far at ``out`` with
the follower's state in their metadata: the same call goes on where it stopped.

Example
-------
>>> import thermrs
>>> for u in thermrs.analyses.watch("live.mcap", "rig.toml", train=["r30.mcap"],
...                                 tolerance_um=50):  # doctest: +SKIP
...     print(u.hours, u.outlook.crossings if u.outlook else None)
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.errors import InputError, RecordingError
from thermrs.fit import fit_alpha, run_name
from thermrs.follow import STATE_KEY, Follower, StepResult
from thermrs.ingest import Extraction, ExtractReport
from thermrs.outlook import Outlook, outlook, run_hours
from thermrs.rig import Rig, as_rig
from thermrs.runtable import run_table_from
from thermrs.visits import anchor_drift

__all__ = ["WatchUpdate", "current_run", "read_partial", "watch"]


@dataclass(frozen=True)
class WatchUpdate:
    """What a watch knows after one read of the recording.

    Attributes
    ----------
    recording
        The recording followed.
    step
        What this update read (bytes, frames) and whether the recording is closed.
    bytes_read
        Bytes of complete records read so far.
    run
        The run being recorded (the recording's last run) as a run table so far (empty before
        its first visit with a spot).
    hours
        Hours from the run's first visit to its last so far.
    temperatures
        The latest reading of each ROI and of the ambient (°C), by name.
    alpha
        ``(α, standard error, source)``: α the outlook uses and where it comes from
        (``"--train"``: fitted on the training runs; ``"so far"``: on the run so far), or None.
    outlook
        The drift to come with its band and when it leaves the tolerance, or None (and
        ``waiting`` says why).
    look
        The sequential diagnosis's latest look (:mod:`thermrs.diagnose.sequential`), or None.
    diagnosis
        Once the recording is closed, with training runs and a stop rule: the diagnosis of
        the finished run (:func:`thermrs.diagnose.diagnose` with the watch's ``exclude`` and
        ``seed``: what ``thermrs diagnose`` gives on the finished file), else None.
    extraction
        The tables so far.
    waiting
        What the watch waits for (nothing read yet, no visit yet, no α yet), or "".
    written
        The tables written when the watch ended (closed or stopped), else empty.
    """

    recording: str
    step: StepResult
    bytes_read: int
    run: pl.DataFrame
    hours: float
    temperatures: dict[str, float]
    alpha: tuple[float, float, str] | None
    outlook: Outlook | None
    look: Any = None
    diagnosis: Any = None
    extraction: Extraction | None = None
    waiting: str = ""
    written: dict[str, Path] = field(default_factory=dict)

    @property
    def closed(self) -> bool:
        """Whether the recording is complete."""
        return self.step.closed

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready document of the update (``thermrs watch --json``).

        Returns
        -------
        dict
            ``recording``, ``closed``, ``bytes_read``, ``hours``, ``visits``,
            ``temperatures_c``, ``alpha`` (``value``, ``stderr``, ``source``), ``outlook``
            (``horizon_h``, ``tolerance_um``, ``crossings``, ``temperatures``, ``notes``),
            ``look``, ``diagnosis`` (at close, ``thermrs diagnose --json``'s document) and
            ``waiting``.
        """
        o = self.outlook
        look = self.look.to_json() if hasattr(self.look, "to_json") else None
        return {
            "recording": self.recording,
            "closed": self.closed,
            "bytes_read": self.bytes_read,
            "hours": self.hours,
            "visits": self.run.height,
            "temperatures_c": self.temperatures,
            "alpha": None
            if self.alpha is None
            else {"value": self.alpha[0], "stderr": self.alpha[1], "source": self.alpha[2]},
            "outlook": None
            if o is None
            else {
                "now_h": o.now_h,
                "horizon_h": o.horizon_h,
                "tolerance_um": o.tolerance_um,
                "crossings": o.crossings.to_dicts(),
                "temperatures": o.temperatures.to_dicts(),
                "notes": list(o.notes),
            },
            "look": look,
            "diagnosis": None if self.diagnosis is None else self.diagnosis.to_json(),
            "waiting": self.waiting or None,
            "written": {k: str(v) for k, v in self.written.items()},
        }


def current_run(ex: Extraction, rig: Rig, *, name: str) -> pl.DataFrame:
    """The run table of the recording's last run so far (the one being recorded).

    Parameters
    ----------
    ex
        The tables so far.
    rig
        The rig.
    name
        The run's name in the table.

    Returns
    -------
    polars.DataFrame
        One row per visit with a spot (:func:`thermrs.fit.run_table_from`), its drift anchored
        at the run's first visit.
    """
    visits, temps = ex.visits, ex.temperatures
    if ex.runs.height == 0 or "run" not in visits.columns:
        return run_table_from(visits, temps, rig, run=name)
    last = ex.runs.sort("start_ns")[-1]
    r = str(last["run"].item())
    v = anchor_drift(visits.filter(pl.col("run") == r))
    tt = temps.filter(pl.col("t_ns") >= int(last["start_ns"].item()))
    label = name if ex.runs.height == 1 else f"{name}#{r}"
    return run_table_from(v, tt, rig, run=label)


def read_partial(out: Path) -> tuple[Extraction, dict[str, Any]] | None:
    """The tables a stopped watch left at ``out`` and its follower's state, if it left any.

    Parameters
    ----------
    out
        The frames file (``OUT.parquet``).

    Returns
    -------
    tuple or None
        The tables and the state, or None (no such file, or the tables of a closed recording).

    Raises
    ------
    InputError
        A file there that is not Parquet.
    """
    if not out.is_file():
        return None
    try:
        meta = pl.read_parquet_metadata(out)
    except (OSError, pl.exceptions.PolarsError) as e:
        raise InputError(f"-o {out}: cannot read it as Parquet: {e}") from None
    raw = meta.get(STATE_KEY)
    if not raw:
        return None
    state = json.loads(raw)
    stem = out.name.removesuffix(".parquet")
    tables = {
        k: pl.read_parquet(out if k == "frames" else out.with_name(f"{stem}.{k}.parquet"))
        for k in ("frames", "visits", "temperatures", "joints", "runs")
    }
    rep = state.get("report") or {}
    fields = ExtractReport.__dataclass_fields__
    report = ExtractReport(
        **{
            "file_bytes": 0,
            "used_summary": False,
            "chunks": 0,
            "messages": {},
            "other_messages": 0,
            "skipped": {},
            "skipped_examples": {},
            "losses": [],
            "recovered_messages": 0,
            **{k: v for k, v in rep.items() if k in fields},
        }
    )
    return (
        Extraction(
            frames=tables["frames"],
            visits=tables["visits"],
            temperatures=tables["temperatures"],
            joints=tables["joints"],
            runs=tables["runs"],
            report=report,
        ),
        state,
    )


def _latest(temps: pl.DataFrame) -> dict[str, float]:
    if temps.height == 0:
        return {}
    last = temps.sort("t_ns").group_by("name", maintain_order=True).last()
    col = "peak_c" if "peak_c" in last.columns else "temperature_c"
    return {str(n): float(t) for n, t in zip(last["name"], last[col], strict=True)}


def _alpha(
    train: Sequence[pl.DataFrame], run: pl.DataFrame, rig: Rig
) -> tuple[float, float, str, float] | None:
    """α, its standard error, where it comes from and the fit's residual rms (µm), from the
    training runs, else from the run so far."""
    if train:
        f = fit_alpha(list(train), rig)
        return f.alpha_per_k, f.stderr, "--train", f.rms_um
    if run.height < 6:
        return None
    try:
        f = fit_alpha([run], rig)
    except InputError:
        return None
    if not (f.ci95[0] > 0 and f.stderr < 0.5 * f.alpha_per_k):
        return None  # the run so far does not determine α yet
    return f.alpha_per_k, f.stderr, "so far", f.rms_um


def watch(
    path: str | os.PathLike[str],
    rig: Rig | str | os.PathLike[str],
    *,
    train: Sequence[pl.DataFrame] = (),
    tolerance_um: float | None = None,
    hours: float | None = None,
    out: str | os.PathLike[str] | None = None,
    poll_s: float = 5.0,
    until_s: float | None = None,
    stop_rule: Any = None,
    sequential: bool = True,
    look_every_h: float = 1.0,
    care_um: float | None = None,
    settle_ambiguous: bool = True,
    exclude: Sequence[str] = (),
    seed: int = 0,
    sleep: Callable[[float], object] = time.sleep,
    clock: Callable[[], float] = time.monotonic,
) -> Iterator[WatchUpdate]:
    """Follow a recording while it is written; yield an update each time it grew.

    Parameters
    ----------
    path, rig
        The recording (an MCAP file, a rosbag2 SQLite database ``.db3``, or a bag folder of
        their parts; it may not exist yet) and the rig (a :class:`~thermrs.Rig` or its file).
    train
        Training run tables: α for the outlook, and the sequential diagnosis's training runs.
        Without them α is fitted on the run so far once it determines it.
    tolerance_um, hours
        A tolerance on either chip axis (µm): when it is left is foreseen; the run's planned
        length (hours from its first visit; default: the longest training run, else twice
        the run so far).
    out
        Where the tables go (``OUT.parquet`` and its siblings, as ``thermrs extract -o``): when
        the recording closes, and, with the follower's state, when the watch is stopped; a
        watch given the ``out`` of a stopped one goes on where it stopped.
    poll_s, until_s
        Seconds between reads while nothing is added; of watching before it stops (the
        tables so far written to ``out``).
    stop_rule, sequential, look_every_h, care_um, settle_ambiguous, exclude
        The sequential diagnosis (needs ``train``): a
        :class:`thermrs.diagnose.sequential.StopRule` given, else with ``sequential`` one
        made over the planned hours with a look every ``look_every_h`` hours of run (its
        ``care_um`` and ``settle_ambiguous``: False for a run ``thermrs design`` planned);
        the effects it never names.
    seed, sleep, clock
        Seed of the outlook's draws and the looks; how to wait and tell the time (tests).

    Yields
    ------
    WatchUpdate
        After each read that added data, and a last one when the recording closes or the
        watch stops.

    Raises
    ------
    InputError
        ``out``'s folder does not exist, or it holds the tables of another recording.
    KeyboardInterrupt
        Ctrl-C: the tables so far are written to ``out`` first.

    Examples
    --------
    >>> for u in watch("live.mcap", "rig.toml", tolerance_um=50, out="live.parquet"):
    ...     print(f"{u.hours:.1f} h", u.waiting or u.outlook.crossings)  # doctest: +SKIP
    """
    rig = as_rig(rig)
    p = Path(path)
    out_p = Path(out) if out is not None else None
    f = _follower(p, rig, out_p)
    name = run_name(p) if p.suffix == ".mcap" else p.name
    train = list(train)
    planned = hours
    if planned is None and train:
        planned = max(run_hours(t) for t in train)
    if stop_rule is None and sequential and train:
        stop_rule = _rule(planned or 15.0, look_every_h, care_um, settle_ambiguous)
    looks = _Looks(stop_rule, train, rig, every_h=look_every_h, exclude=exclude, seed=seed)
    started = clock()
    first = True
    try:
        while True:
            step = f.step()
            stopping = until_s is not None and clock() - started >= until_s
            if step.bytes_read or first or step.closed or stopping:
                first = False
                u = looks.at(_update(f, rig, name, step, train, tolerance_um, planned, seed))
                if step.closed or stopping:
                    yield replace(u, written=_write(f, u, out_p, final=step.closed))
                    return
                yield u
            sleep(poll_s)
    except (KeyboardInterrupt, GeneratorExit):
        # Ctrl-C, or the caller stopped taking updates: the tables so far, to go on from.
        if out_p is not None and f.bytes_read and not f.closed:
            _write(f, None, out_p, final=False)
        raise


def _follower(path: Path, rig: Rig, out: Path | None) -> Follower:
    """A follower of ``path``, going on from the tables a stopped watch left at ``out``."""
    if out is not None and not out.parent.is_dir():
        raise InputError(f"-o {out}: no such folder {out.parent}")
    state = read_partial(out) if out is not None else None
    if state is None:
        return Follower(path, rig)
    return Follower(path, rig, state=state[1], resumed=state[0])


def _rule(planned_h: float, every_h: float, care_um: float | None, settle: bool) -> Any:
    """The stop rule over the planned hours (bad options as one line)."""
    from thermrs.diagnose.sequential import StopRule

    try:
        return StopRule(
            planned_hours=planned_h,
            look_every_h=min(every_h, planned_h),
            care_um=care_um,
            settle_ambiguous=settle,
        )
    except ValueError as e:
        raise InputError(f"the sequential diagnosis: {e}") from None


class _Looks:
    """The sequential diagnosis's looks as the run grows, and the diagnosis of the finished
    run (the one ``thermrs diagnose`` gives on it) once the recording closes."""

    def __init__(
        self,
        rule: Any,
        train: Sequence[pl.DataFrame],
        rig: Rig,
        *,
        every_h: float,
        exclude: Sequence[str],
        seed: int,
    ) -> None:
        self.rule, self.train, self.rig = rule, list(train), rig
        self.every_h, self.exclude, self.seed = every_h, tuple(exclude), seed
        self.next_h = every_h
        self.last: Any = None

    def at(self, u: WatchUpdate) -> WatchUpdate:
        if self.rule is None or not self.train or u.run.height == 0:
            return u
        if not self.rule.stopped and u.hours >= self.next_h:
            self.last = self.rule.look(
                self.train, u.run, self.rig, hours=u.hours, exclude=self.exclude, seed=self.seed
            )
            self.next_h = (int(u.hours / self.every_h) + 1) * self.every_h
        final = None
        if u.closed:
            from thermrs.diagnose import diagnose

            final = diagnose(self.train, [u.run], self.rig, exclude=self.exclude, seed=self.seed)
        return replace(u, look=self.last, diagnosis=final)


def _update(
    f: Follower,
    rig: Rig,
    name: str,
    step: StepResult,
    train: Sequence[pl.DataFrame],
    tolerance_um: float | None,
    planned: float | None,
    seed: int,
) -> WatchUpdate:
    empty = pl.DataFrame()
    base = WatchUpdate(
        recording=str(f.path),
        step=step,
        bytes_read=f.bytes_read,
        run=empty,
        hours=0.0,
        temperatures={},
        alpha=None,
        outlook=None,
    )
    try:
        ex = f.extraction()
    except RecordingError:
        return replace(base, waiting="nothing of the rig's cameras read yet")
    run = current_run(ex, rig, name=name)
    temps = _latest(ex.temperatures)
    base = replace(base, extraction=ex, run=run, temperatures=temps, hours=run_hours(run))
    if run.height == 0:
        return replace(base, waiting="no visit with a spot yet")
    alpha = _alpha(train, run, rig)
    if alpha is None:
        return replace(base, waiting="α not determined yet by the run so far (give --train runs)")
    horizon = planned if planned is not None else max(2.0 * base.hours, base.hours + 1.0)
    try:
        o = outlook(
            run,
            rig,
            alpha_per_k=alpha[0],
            alpha_se=alpha[1],
            horizon_h=horizon,
            tolerance_um=tolerance_um,
            noise_um=alpha[3],
            seed=seed,
        )
    except InputError as e:
        return replace(base, alpha=alpha[:3], waiting=str(e))
    return replace(base, alpha=alpha[:3], outlook=o)


def _write(f: Follower, u: WatchUpdate | None, out: Path | None, *, final: bool) -> dict[str, Path]:
    """The tables so far at ``out``: as ``extract -o`` leaves them once the recording is
    closed, else with the follower's state to go on from."""
    if out is None:
        return {}
    ex = u.extraction if u is not None and u.extraction is not None else None
    if ex is None:
        try:
            ex = f.extraction()
        except RecordingError:
            return {}
    if final:
        return ex.write(out)
    return ex.write(out, metadata={STATE_KEY: json.dumps(f.state())})
