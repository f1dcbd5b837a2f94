"""The exceptions thermrs raises on purpose.

Every one derives from :class:`ThermrsError`; the CLI turns them into one line on stderr and
exit code 2 (bad input), see SPEC §7.
"""

from thermrs._native import InputError, RecordingError, RigError, ScenarioError, ThermrsError

__all__ = ["InputError", "RecordingError", "RigError", "ScenarioError", "ThermrsError"]
