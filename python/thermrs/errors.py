"""The exceptions thermrs raises on purpose.

Every one derives from :class:`ThermrsError`; the CLI turns them into one line on stderr and
exit code 2 (bad input), see SPEC §7, except :class:`InternalError` (a bug in thermrs: a
panic in the Rust core, caught and turned into one line), which exits 1.
"""

from thermrs._native import (
    InputError,
    InternalError,
    RecordingError,
    RigError,
    ScenarioError,
    ThermrsError,
)

__all__ = [
    "InputError",
    "InternalError",
    "RecordingError",
    "RigError",
    "ScenarioError",
    "ThermrsError",
]
