"""The errors of every command, and the exit codes they end with (docs/guarantees.md,
"Exit codes": one table for every command).

=====  ==================================================================================
code   meaning
=====  ==================================================================================
0      done (or nothing left to do: ``--resume`` of a finished output)
1      a fault outside the input after work began (a full disk, a file-size limit, an I/O
       error, chunks that failed on a cluster); what was finished is kept
2      bad input: a scene, an option, a path or a file that cannot be used, refused before
       any work
130    interrupted (Ctrl-C, SIGTERM); what was finished is kept, and the message says where
=====  ==================================================================================
"""

EXIT_DONE = 0
EXIT_FAULT = 1
EXIT_INPUT = 2
EXIT_INTERRUPTED = 130


class SweepError(Exception):
    """A command that cannot start or continue; the message says what to do.  Bad input
    unless a subclass says otherwise (``exit_code``)."""

    exit_code = EXIT_INPUT


class SweepInterrupted(SweepError):
    """The command was interrupted; the message says what was kept and how to go on."""

    exit_code = EXIT_INTERRUPTED


class Fault(SweepError):
    """A failure outside the input after work began (not a write: e.g. chunks that failed
    on a cluster); what was finished is kept."""

    exit_code = EXIT_FAULT


class WriteFailed(Fault):
    """The output could not take the next block (no space, a file-size limit, an I/O
    error); every block marked done before it is kept, and --resume completes the file.

    ``broken``: a write failed inside HDF5 (not refused beforehand), so this process's
    HDF5 state is unusable: the command ends at once, without HDF5's clean-up."""

    def __init__(self, msg, broken=False):
        super().__init__(msg)
        self.broken = broken
