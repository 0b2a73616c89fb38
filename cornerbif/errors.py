"""The errors of a sweep, shared by the engine's backends, the file and the command."""


class SweepError(Exception):
    """A sweep that cannot start or continue; the message says what to do."""


class SweepInterrupted(SweepError):
    """The sweep was interrupted; finished points are kept in the partial file."""


class WriteFailed(SweepError):
    """The output could not take the next block (no space, a file-size limit, an I/O
    error); every block marked done before it is kept, and --resume completes the file.

    ``broken``: a write failed inside HDF5 (not refused beforehand), so this process's
    HDF5 state is unusable: the command ends at once, without HDF5's clean-up."""

    def __init__(self, msg, broken=False):
        super().__init__(msg)
        self.broken = broken
