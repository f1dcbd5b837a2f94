"""The files a design writes: the user's rig plus what a candidate adds (``rig.toml``), the runs
to record (``scenario.toml``, ``thermrs-scenario/1``), both checked by the parsers that read
them (the rig by the Rust core, with the laser checked to meet every pose's own chip)."""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import tomli_w

from thermrs.atomic import write_text as write_text_atomic
from thermrs.design.measurements import Candidate
from thermrs.rig import Rig

__all__ = ["rig_dict", "rig_toml", "scenario_toml", "write_text_atomic"]

#: Largest angle (degrees) between the beam and a new chip's normal the design accepts.
MAX_INCIDENCE_DEG = 2.0


def _clean(x: Any) -> Any:
    """Drop None values (TOML has no null)."""
    if isinstance(x, Mapping):
        return {k: _clean(v) for k, v in x.items() if v is not None}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    return x


def rig_dict(
    rig: Rig, candidate: Candidate | None, *, alpha_per_k: float | None = None
) -> dict[str, Any]:
    """The rig's file keys with the candidate's pose and chip added (and α replaced, for a
    simulated truth)."""
    d: dict[str, Any] = _clean(copy.deepcopy(rig.to_dict()))
    if candidate is not None and candidate.camera is not None and candidate.pose is not None:
        d["camera"] = [*d["camera"], dict(candidate.camera)]
        d["pose"] = [*d["pose"], dict(candidate.pose)]
    if alpha_per_k is not None:
        d["expansion"]["alpha_per_k"] = float(alpha_per_k)
    return d


def rig_toml(
    rig: Rig, candidate: Candidate | None, *, alpha_per_k: float | None = None
) -> tuple[str, Rig]:
    """The new rig file's text and the rig it parses to (checked: the laser meets every pose's
    own chip; a new chip near its centre, at most :data:`MAX_INCIDENCE_DEG` off its normal).

    Raises
    ------
    RigError
        The new rig does not validate (a bug of the design: the chip is placed on the beam).
    """
    d = rig_dict(rig, candidate, alpha_per_k=alpha_per_k)
    head = "# Written by `thermrs design`: the user's rig plus the recommended pose and chip.\n"
    text = head + tomli_w.dumps(d)
    new = Rig.from_toml(text, source_name="design rig.toml")
    view = new.check()
    if candidate is not None and candidate.camera is not None:
        name = candidate.camera["name"]
        inc = view["poses"][name]["incidence_deg"][name]
        if inc is None or inc > MAX_INCIDENCE_DEG:
            from thermrs.errors import RigError

            raise RigError(f"design rig: the laser meets chip {name} at {inc}° incidence")
    return text, new


def scenario_toml(
    candidate: Candidate,
    *,
    cycle_s: float,
    name: str,
    effects: Sequence[Mapping[str, Any]] = (),
    extra: Mapping[str, Any] | None = None,
    seed: int | None = None,
) -> str:
    """The scenario of the candidate's runs (``thermrs-scenario/1``); ``effects`` and ``extra``
    tables (``[camera]``, ``[motion]`` …) only for the proof's simulations."""
    d: dict[str, Any] = {"format": "thermrs-scenario/1", "name": name}
    if seed is not None:
        d["seed"] = int(seed)
    d["run"] = [r.to_scenario(cycle_s) for r in candidate.protocol.runs]
    if candidate.protocol.ambient:
        d["ambient"] = dict(candidate.protocol.ambient)
    for k, v in (extra or {}).items():
        d[k] = {**d.get(k, {}), **dict(v)}
    if effects:
        d["effect"] = [dict(e) for e in effects]
    return tomli_w.dumps(_clean(d))
