"""The ``cornerbif`` command's entry point: the command line (``cornerbif.cli``) behind a
guard for the moments before its commands take over signals.

Importing the command line takes a few tenths of a second (click, numpy, the package).  A
Ctrl-C or a SIGTERM in that time, or while click reads the arguments, would otherwise end
the process with Python's traceback (SIGINT) or with no word at all (SIGTERM); here it ends
as every command's interrupt does: "error: interrupted", exit 130 (``cornerbif.errors``).
Nothing has been written by then.  From ``cli.Commands.invoke`` on, each command's own
handlers answer (``outputs.install_signal_handlers``).
"""

import signal
import sys

EXIT_INTERRUPTED = 130          # cornerbif.errors.EXIT_INTERRUPTED (not imported: it is early)


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _interrupted():
    try:
        sys.stderr.write("error: interrupted\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    sys.exit(EXIT_INTERRUPTED)


def main():
    """``cornerbif ...``: SIGINT and SIGTERM raise ``KeyboardInterrupt`` from the first
    moment; one met before a command runs ends the process with exit 130."""
    try:
        signal.signal(signal.SIGTERM, _interrupt)
        signal.signal(signal.SIGINT, _interrupt)
        # start-up: the command line loads click and the registries, after the handlers
        from .cli import main as cli_main
    except KeyboardInterrupt:
        _interrupted()
    try:
        return cli_main()
    except KeyboardInterrupt:
        _interrupted()


if __name__ == "__main__":
    main()
