"""Typed errors. The CLI prints any of these as one line and exits non-zero."""


class ShockdynoError(Exception):
    """Base of every error that is the user's or the rig's, not a bug."""

    exit_code = 2


class ConfigError(ShockdynoError):
    """A rig file, damper spec, scenario or command-line value is wrong."""


class RigFault(ShockdynoError):
    """The rig (real or simulated) reported a fault, timed out or breached a limit."""

    exit_code = 3


class RecordingError(ShockdynoError):
    """A recording or CSV file cannot be read or written as asked."""


class FitError(ShockdynoError):
    """A fit cannot be done on the data given."""
