"""thermrs: measure, model and predict the temperature-induced drift of industrial robots.

The heavy lifting is Rust (``thermrs._native``); this package is the library API:

- :mod:`thermrs.rig`: rig files (load, validate, explain);
- :mod:`thermrs.model`: the thermal-expansion forward model, vectorised over time series;
- :mod:`thermrs.paper`: the KR 15/2 paper's own model and its Tables 6 and 7.
"""

from importlib.metadata import PackageNotFoundError, version

from thermrs import paper
from thermrs.errors import InputError, RecordingError, RigError, ThermrsError
from thermrs.ingest import Extraction, extract
from thermrs.model import ForwardModel, Spots
from thermrs.rig import Rig, default_rig_path, load_rig

try:
    __version__ = version("thermrs")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = [
    "Extraction",
    "ForwardModel",
    "InputError",
    "RecordingError",
    "Rig",
    "RigError",
    "Spots",
    "ThermrsError",
    "__version__",
    "default_rig_path",
    "extract",
    "load_rig",
    "paper",
]
