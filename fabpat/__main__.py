"""``python -m fabpat`` and the ``fabpat`` console script.

The CLI is imported inside :func:`run`, so a Ctrl-C while its modules load (click, numpy, …: the
first half second) ends with the same one line and exit code 130 as one during a command; and
:func:`run` handles SIGTERM before it imports anything, so a SIGTERM in that first half second ends
with ``fabpat: terminated`` and 143 too, instead of the silent default death.
"""

import sys

if __name__ == "__main__":  # ``python -m fabpat``: one module, whichever name imports it (TERMINATED is shared)
    sys.modules.setdefault("fabpat.__main__", sys.modules[__name__])

#: the signals that ended the run through :func:`on_sigterm` (read by the CLI for the exit code)
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


def run() -> None:
    """The console entry point: SIGTERM handled first, then the CLI imported and run."""
    import signal

    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:  # an ignored SIGTERM (SIG_IGN) stays ignored
        signal.signal(signal.SIGTERM, on_sigterm)
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
    """``fabpat: interrupted`` on stderr and exit code 130 (128 + SIGINT), or ``fabpat: terminated``
    and 143 (128 + SIGTERM) when SIGTERM ended the run."""
    forget_interrupt()
    if TERMINATED:
        sys.stderr.write("fabpat: terminated\n")
        sys.exit(128 + TERMINATED[0])
    sys.stderr.write("fabpat: interrupted\n")
    sys.exit(130)


if __name__ == "__main__":
    run()
