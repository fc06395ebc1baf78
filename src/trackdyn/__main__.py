"""``python -m trackdyn`` and the ``trackdyn`` command.

Interrupts are handled before anything heavy is imported, and the process ends without
the interpreter's slow shutdown (where Python gives SIGINT back its default action), so
Ctrl-C ends the command with exit code 130 and no partial output at any moment
(`trackdyn.commands.staging`). The garbage collector runs less often than Python's default
(`trackdyn.commands.staging.collect_rarely`): a command's process lives seconds.
"""

import os
import signal
import sys


def _exit_interrupted(signum, frame) -> None:
    os._exit(130)  # before anything is written there is nothing to clean up


def main():
    """Run the command-line interface."""
    for sig in (signal.SIGINT, signal.SIGTERM):  # first thing, before any heavy import
        signal.signal(sig, _exit_interrupted)
    from trackdyn.commands.staging import collect_rarely, handle_interrupts

    handle_interrupts()
    collect_rarely()
    from trackdyn.cli import app

    try:
        app(prog_name="trackdyn")
        code = 0
    except SystemExit as exc:
        code = exc.code
    if not isinstance(code, int):
        if code is not None:
            print(code, file=sys.stderr)
        code = 0 if code is None else 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    main()
