"""The exceptions thermrs raises on purpose.

Every one of bad input derives from :class:`ThermrsError`; the CLI turns them into one line on
stderr and exit code 2 (bad input), see SPEC §7, except :class:`InternalError` (a bug in
thermrs: a panic in the Rust core, caught and turned into one line), which exits 1.

:class:`OutputError` is not bad input: an output the system would not take (a read-only
folder, a full disk). It is the ``OSError`` the Rust core's write errors become (errno, reason
and the file), typed, so that the CLI says ``error: cannot write PATH: reason`` and exits 1.
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
    "OutputError",
    "RecordingError",
    "RigError",
    "ScenarioError",
    "ThermrsError",
]


class OutputError(OSError):
    """An output that could not be written, as ``OutputError(errno, reason, path)``:
    ``errno`` the operating system's (None when the writer lost it), ``filename`` the file
    asked for (never the temporary beside it); ``str()`` is ``cannot write PATH: reason``."""

    def __str__(self) -> str:
        reason = self.strerror or (str(self.args[0]) if self.args else "failed")
        return f"cannot write {self.filename}: {reason}"
