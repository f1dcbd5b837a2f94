"""Type stubs of the compiled core bindings (``rust/thermrs-py``).

Errors (the one mapping, ``rust/thermrs-py/src/errors.rs``, names every core variant):
bad input is a :class:`ThermrsError` subclass -- :class:`RigError` (a rig file, or a pose whose
own camera the laser misses), :class:`ScenarioError`, :class:`RecordingError` (not MCAP, none
of the rig's topics, a chunk that does not decompress), :class:`InputError` (names, values,
shapes, effects, unreadable files) -- and the CLI exits 2 for it. A failed write (a full disk,
no permission, a closed pipe) is **not** a ``ThermrsError``: it is ``OSError(errno, strerror,
filename)`` (Python picks the subclass by errno, e.g. ``PermissionError``) naming the file,
and the CLI exits 1 for it. A panic in the core is :class:`InternalError` (exit 1); Ctrl-C is
``KeyboardInterrupt`` (exit 130).
"""

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__version__: str

class ThermrsError(Exception):
    """Base class of every error thermrs raises on purpose."""

class RigError(ThermrsError):
    """A rig file that does not parse or does not validate; the message names the key."""

class RecordingError(ThermrsError):
    """A recording that cannot be used: not MCAP, or none of the rig's topics in it."""

class ScenarioError(ThermrsError):
    """A scenario file that does not parse or does not validate; the message names the key."""

class InputError(ThermrsError):
    """Arguments or data that do not fit: shapes, names, values, unreadable files."""

class InternalError(ThermrsError):
    """A bug in thermrs (a panic in the core), reported as one line instead of a crash."""

def _panic_for_tests(*, guarded: bool = True) -> None: ...

Progress = Callable[[int, int], object]

class Rig:
    @staticmethod
    def from_path(path: str) -> Rig: ...
    @staticmethod
    def from_json(text: str, source_name: str = "<json>") -> Rig: ...
    @staticmethod
    def from_toml(text: str, source_name: str = "<string>") -> Rig: ...
    def to_json(self) -> str: ...
    def explain_json(self) -> str: ...
    def tolerances_json(self) -> str: ...
    def tolerances_stated(self) -> bool: ...
    def mapped_temperatures(self) -> list[str]: ...

class ForwardModel:
    def __init__(
        self,
        rig: Rig,
        *,
        alpha_per_k: float | None = None,
        reference_c: float | None = None,
        effects_json: str | None = None,
    ) -> None: ...
    def temperature_names(self) -> list[str]: ...
    def has_lag(self) -> bool: ...
    def shifts_chips(self) -> bool: ...
    def structure_temperatures(
        self, t_s: npt.NDArray[np.float64], x: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]: ...
    def has_mount_lag(self, camera: str) -> bool: ...
    def mount_temperatures(
        self, camera: str, t_s: npt.NDArray[np.float64], x: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]: ...
    def chip_shifts(
        self,
        camera: str,
        ambient_c: npt.NDArray[np.float64],
        t_since_start_s: npt.NDArray[np.float64],
        mount_c: npt.NDArray[np.float64] | None = None,
    ) -> npt.NDArray[np.float64]: ...
    def flange_positions(
        self,
        q: npt.NDArray[np.float64],
        temperatures: Sequence[npt.NDArray[np.float64]] | None = None,
        progress: Progress | None = None,
    ) -> npt.NDArray[np.float64]: ...
    def flange_transforms(
        self,
        q: npt.NDArray[np.float64],
        temperatures: Sequence[npt.NDArray[np.float64]] | None = None,
        progress: Progress | None = None,
    ) -> npt.NDArray[np.float64]: ...
    def spots(
        self,
        camera: str,
        q: npt.NDArray[np.float64],
        temperatures: Sequence[npt.NDArray[np.float64]] | None = None,
        progress: Progress | None = None,
    ) -> npt.NDArray[np.float64]: ...

def effect_names() -> list[str]: ...
def effect_check(json: str, rig: Rig | None = None) -> str: ...
def num_threads() -> int: ...
def status_names() -> list[str]: ...
def decompress_chunks(path: str) -> tuple[int, int, int]: ...
def checksum_chunks(path: str) -> tuple[int, int, int]: ...
def inventory(path: str, topics: list[str] | None = None) -> str: ...
def content_hash(path: str) -> str: ...
def is_bag(path: str) -> bool: ...
def bag_parts(path: str) -> list[str]: ...

class Follower:
    """Follows an MCAP file or a rosbag2 SQLite database while it is written: each ``step``
    reads only the complete records (the committed rows) added since the last."""

    def __init__(self, path: str, *, state: str | None = None) -> None: ...
    def step(
        self,
        rig: Rig,
        *,
        progress: Callable[[int, int, int], object] | None = None,
        min_sigma_px: float | None = None,
        threshold_sigma: float | None = None,
        verify_crc: bool = True,
    ) -> tuple[
        tuple[
            dict[str, npt.NDArray[Any]],
            dict[str, npt.NDArray[Any]],
            dict[str, npt.NDArray[Any]],
            dict[str, npt.NDArray[Any]],
            str,
        ],
        int,
        int,
        bool,
    ]: ...
    def state_json(self) -> str: ...
    @property
    def position(self) -> int: ...
    @property
    def closed(self) -> bool: ...
    def topics(self) -> list[str]: ...

def extract(
    path: str,
    rig: Rig,
    *,
    progress: Callable[[int, int, int], object] | None = None,
    min_sigma_px: float | None = None,
    threshold_sigma: float | None = None,
    verify_crc: bool = True,
    content_hash: bool = False,
) -> tuple[
    dict[str, npt.NDArray[Any]],
    dict[str, npt.NDArray[Any]],
    dict[str, npt.NDArray[Any]],
    dict[str, npt.NDArray[Any]],
    str,
]: ...
def simulate(
    rig: Rig,
    scenario_toml: str,
    out_path: str | None,
    *,
    source_name: str = "<string>",
    seed: int | None = None,
    cancel: Callable[[], bool] | None = None,
) -> tuple[dict[str, Any], str]:
    """Simulate; a failed write raises ``OSError`` naming ``out_path`` (not a ThermrsError).
    ``out_path=None``: the truth alone, nothing rendered or written. ``cancel()`` true: stop
    with ``KeyboardInterrupt``."""
    ...
