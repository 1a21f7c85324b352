"""``python -m fabpat`` and the ``fabpat`` console script.

The CLI is imported inside :func:`run`, so a Ctrl-C while its modules load (click, numpy, …: the
first half second) ends with the same one line and exit code 130 as one during a command; and
:func:`run` handles SIGTERM before it imports anything, so a SIGTERM in that first half second ends
with ``fabpat: terminated`` and 143 too, instead of the silent default death (the handler and the exit
line live in :mod:`fabpat.interrupts`, shared with the CLI).
"""

def run() -> None:
    """The console entry point: SIGTERM handled first, then the CLI imported and run."""
    import signal

    from fabpat.interrupts import exit_interrupted, on_sigterm  # imports only sys

    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:  # an ignored SIGTERM (SIG_IGN) stays ignored
        signal.signal(signal.SIGTERM, on_sigterm)
    try:
        from fabpat.cli import main

        main()
    except KeyboardInterrupt:
        exit_interrupted()
    except ImportError as e:  # a C extension reports a Ctrl-C during its import as ImportError
        if isinstance(e.__cause__ or e.__context__, KeyboardInterrupt):
            exit_interrupted()
        raise


if __name__ == "__main__":
    run()
