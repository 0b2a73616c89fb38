"""The errors of a sweep, shared by the engine's backends, the file and the command."""


class SweepError(Exception):
    """A sweep that cannot start or continue; the message says what to do."""


class SweepInterrupted(SweepError):
    """The sweep was interrupted; finished points are kept in the partial file."""
