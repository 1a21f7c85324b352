"""``python -m fabpat`` and the ``fabpat`` console script.

The CLI is imported inside :func:`run`, so a Ctrl-C while its modules load (click, numpy, …: the
first half second) ends with the same one line and exit code 130 as one during a command.
"""

import sys


def forget_interrupt() -> None:
    """Clear CPython's "unhandled KeyboardInterrupt" flag before exiting with 130.

    A Ctrl-C that lands inside code run by ``exec(string)`` (scipy runs its imports that way) sets
    that flag even when fabpat catches the exception, and the interpreter then kills itself with
    SIGINT at exit (exit status −2 instead of 130). Every ``exec`` of a string resets the flag first
    (CPython 3.11 ``run_eval_code_obj``), so one harmless ``exec`` clears it.
    """
    exec("pass")  # noqa: S102 - a constant string, see the docstring


def run() -> None:
    try:
        from fabpat.cli import main

        main()
    except KeyboardInterrupt:
        interrupted()
    except ImportError as e:  # a C extension reports a Ctrl-C during its import as ImportError
        if isinstance(e.__cause__ or e.__context__, KeyboardInterrupt):
            interrupted()
        raise


def interrupted() -> None:
    """``fabpat: interrupted`` on stderr and exit code 130 (128 + SIGINT)."""
    sys.stderr.write("fabpat: interrupted\n")
    forget_interrupt()
    sys.exit(130)


if __name__ == "__main__":
    run()
