"""How a signal ends a fabpat run: SIGTERM unwinds like Ctrl-C, and the exit is one line and 128 + signal.

Shared by the console entry point (:mod:`fabpat.__main__`, which installs :func:`on_sigterm` before it
imports anything heavy) and the CLI (:mod:`fabpat.cli`, which turns an interruption in a command into the
same line), so both read one :data:`TERMINATED` list. This module imports nothing but :mod:`sys`: the
entry point loads it in the first milliseconds of a run.
"""

import sys

#: the signals that ended the run through :func:`on_sigterm` (read for the exit code)
TERMINATED: list[int] = []


def on_sigterm(signum: int, frame: object) -> None:
    """SIGTERM unwinds like Ctrl-C, so every ``finally`` runs: temporary files and folders are
    removed and the catalog's committed rows stay (the default action would end the process at once)."""
    TERMINATED.append(signum)
    raise KeyboardInterrupt


def forget_interrupt() -> None:
    """Clear CPython's "unhandled KeyboardInterrupt" flag before exiting with 130.

    A Ctrl-C that lands inside code run by ``exec(string)`` (scipy runs its imports that way) sets
    that flag even when fabpat catches the exception, and the interpreter then kills itself with
    SIGINT at exit (exit status −2 instead of 130). Every ``exec`` of a string resets the flag first
    (CPython 3.11 ``run_eval_code_obj``), so one harmless ``exec`` clears it.
    """
    exec("pass")  # noqa: S102 - a constant string, see the docstring


def interrupt_status() -> tuple[str, int]:
    """What ended the run and its exit code: ``("terminated", 143)`` after SIGTERM (128 + 15),
    ``("interrupted", 130)`` after Ctrl-C (128 + SIGINT, the shell's convention)."""
    if TERMINATED:
        return "terminated", 128 + TERMINATED[0]
    return "interrupted", 130


def exit_interrupted() -> None:
    """``fabpat: interrupted`` (or ``terminated``) on stderr and exit with :func:`interrupt_status`'s code."""
    forget_interrupt()
    word, code = interrupt_status()
    sys.stderr.write(f"fabpat: {word}\n")
    sys.exit(code)
