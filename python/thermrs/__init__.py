"""thermrs: measure, model and predict the temperature-induced drift of industrial robots.

The heavy lifting is Rust (``thermrs._native``); this package is the library API:

- :mod:`thermrs.rig`: rig files (load, validate, explain);
- :mod:`thermrs.model`: the thermal-expansion forward model, vectorised over time series;
- :mod:`thermrs.ingest`: recordings to tables (:func:`thermrs.extract`);
- :mod:`thermrs.fit`: the fit of the expansion coefficient α on run tables
  (:mod:`thermrs.runtable`);
- :mod:`thermrs.predict`: predicted against measured drift (Table 7 for any runs);
- :mod:`thermrs.heating`: first-order heating curves;
- :mod:`thermrs.iso9283`: ISO 9283-style pose figures;
- :mod:`thermrs.simulate`: the simulator (a rig at work under a scenario);
- :mod:`thermrs.paper`: the KR 15/2 paper's own model and its Tables 6 and 7;
- :mod:`thermrs.runs`: runs inside a recording (found by :mod:`thermrs.rundetect`), files to
  run tables; :mod:`thermrs.inventory`: what a recording
  holds, from its summary;
- :mod:`thermrs.effects`, :mod:`thermrs.signatures`, :mod:`thermrs.diagnose`: the SPEC §6
  effects and the diagnosis of the sim-to-real gap; :mod:`thermrs.compensate`: the diagnosed
  model put to use; :mod:`thermrs.stats`: least squares and its covariance;
- :mod:`thermrs.follow`, :mod:`thermrs.outlook`: a recording followed while it is written and
  the rest of its run foreseen (:func:`thermrs.watch`, a generator of updates);
- :mod:`thermrs.report`: the report a person reads; :mod:`thermrs.atomic`: outputs written
  atomically.

Every submodule and name below is reachable right after ``import thermrs``; each is imported
on first use, so that ``import thermrs`` (and ``thermrs --help``) stay fast.

Example
-------
>>> import thermrs
>>> rig = thermrs.load_rig()
>>> callable(thermrs.fit.fit_alpha) and issubclass(thermrs.ScenarioError, thermrs.ThermrsError)
True
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from thermrs import (
        campaigns,
        compensate,
        design,
        diagnose,
        effects,
        fit,
        follow,
        heating,
        ingest,
        inventory,
        iso9283,
        model,
        outlook,
        paper,
        predict,
        report,
        rig,
        runs,
        signatures,
        simulate,
        stats,
    )
    from thermrs.analyses.watch import watch
    from thermrs.campaigns import campaign
    from thermrs.errors import (
        InputError,
        InternalError,
        OutputError,
        RecordingError,
        RigError,
        ScenarioError,
        ThermrsError,
    )
    from thermrs.ingest import Extraction, extract
    from thermrs.model import ForwardModel, Spots
    from thermrs.rig import Rig, default_rig_path, load_rig

__version__: str  # read from the installed package's metadata on first use

#: Submodules imported on first attribute access.
_SUBMODULES = (
    "campaigns",
    "compensate",
    "design",
    "diagnose",
    "effects",
    "errors",
    "fit",
    "follow",
    "heating",
    "ingest",
    "inventory",
    "iso9283",
    "model",
    "outlook",
    "paper",
    "predict",
    "report",
    "rig",
    "runs",
    "signatures",
    "simulate",
    "stats",
    "visits",
    "analyses",
)

#: Names re-exported at the top level: name → module that defines it.
_NAMES = {
    "campaign": "thermrs.campaigns",
    "Extraction": "thermrs.ingest",
    "extract": "thermrs.ingest",
    "ForwardModel": "thermrs.model",
    "Spots": "thermrs.model",
    "Rig": "thermrs.rig",
    "default_rig_path": "thermrs.rig",
    "load_rig": "thermrs.rig",
    "InputError": "thermrs.errors",
    "InternalError": "thermrs.errors",
    "OutputError": "thermrs.errors",
    "RecordingError": "thermrs.errors",
    "RigError": "thermrs.errors",
    "ScenarioError": "thermrs.errors",
    "ThermrsError": "thermrs.errors",
    "watch": "thermrs.analyses.watch",
}

__all__ = [
    "Extraction",
    "ForwardModel",
    "InputError",
    "InternalError",
    "OutputError",
    "RecordingError",
    "Rig",
    "RigError",
    "ScenarioError",
    "Spots",
    "ThermrsError",
    "__version__",
    "analyses",
    "campaign",
    "campaigns",
    "compensate",
    "default_rig_path",
    "design",
    "diagnose",
    "effects",
    "extract",
    "fit",
    "follow",
    "heating",
    "ingest",
    "inventory",
    "iso9283",
    "load_rig",
    "model",
    "outlook",
    "paper",
    "predict",
    "report",
    "rig",
    "runs",
    "signatures",
    "simulate",
    "stats",
    "visits",
    "watch",
]


def __getattr__(name: str) -> Any:
    """Import a submodule or a re-exported name on first use (PEP 562)."""
    value: Any
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("thermrs")
        except PackageNotFoundError:  # pragma: no cover - running from a source tree
            value = "0.0.0"
    elif name in _NAMES:
        value = getattr(importlib.import_module(_NAMES[name]), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f"thermrs.{name}")
    else:
        raise AttributeError(f"module 'thermrs' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | set(_SUBMODULES))
