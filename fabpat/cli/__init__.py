"""The ``fabpat`` command line: each subcommand parses its options and calls the library.

Errors never show a traceback: a :class:`~fabpat.errors.FabpatError` or a usage error becomes one
line on stderr (``fabpat: error: …``) and exit code 2; Ctrl-C becomes ``fabpat: interrupted`` and
exit code 130 (128 + SIGINT, the shell's convention), SIGTERM ``fabpat: terminated`` and 143, for
every command (:func:`interrupt_status`).
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator
from typing import Any

import click

from fabpat import __version__
from fabpat.errors import FabpatError
from fabpat.interrupts import TERMINATED as _TERMINATED  # one list with the entry point's SIGTERM handler
from fabpat.interrupts import interrupt_status
from fabpat.interrupts import on_sigterm as _on_sigterm

#: deprecation notices of the running command (:func:`deprecated`), said once it has run
_NOTICES: list[str] = []


def deprecated(old: str, new: str) -> None:
    """Call from a deprecated alias: after the command succeeds, one warning line says to use ``new``;
    if it fails, the error line alone is printed, ending with the notice (one line, as every error)."""
    _NOTICES.append(f"{old} is deprecated and will be removed in the next release: use {new} "
                    "(same options and output)")


@contextlib.contextmanager
def _sigterm_unwinds() -> Iterator[None]:
    """Handle SIGTERM with :func:`_on_sigterm` for the block, then restore the previous handler
    (the CLI also runs inside other programs: tests, notebooks)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():  # handlers live in the main thread
        yield
        return
    _TERMINATED.clear()
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[Callable[[], None]]:
    """Inside the block a Ctrl-C or SIGTERM is noted, not raised; the yielded ``checkpoint()`` raises it
    (as KeyboardInterrupt, SIGTERM recorded as by :func:`_on_sigterm`) where the caller knows it is safe,
    and leaving the block does, after the previous handlers are back. A second signal while one is
    pending is raised at once (a user who presses Ctrl-C twice wants out); a signal that was ignored
    (SIG_IGN, e.g. a background job's SIGINT) stays ignored; if the block ends with another exception,
    the interrupt is raised from it (the CLI then still exits 130 or 143).

    Why: an interrupt raised at an arbitrary point can land inside an import (ezdxf loads submodules
    while the first DXF is written) or a finalizer; CPython then prints "Exception ignored" and goes on,
    and measured runs then hung on an import lock or aborted (exit −6) instead of cleaning up. The
    export holds interrupts for one part at a time (:func:`fabpat.exchange.registry.export_parts`'s
    ``part_guard``), so one arriving during the last part still stops the run before its files are
    committed. Outside the main thread, where handlers cannot be set, signals behave as usual.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield lambda: None
        return
    pending: list[int] = []

    def note(signum: int, frame: object) -> None:
        pending.append(signum)
        if len(pending) > 1:
            checkpoint()

    def checkpoint() -> None:
        if pending:
            signum = pending[0]
            pending.clear()
            if signum == signal.SIGTERM:
                _TERMINATED.append(signum)
            raise KeyboardInterrupt

    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    held = [s for s, handler in previous.items() if handler is not signal.SIG_IGN]
    for s in held:
        signal.signal(s, note)
    try:
        yield checkpoint
    except BaseException as e:
        if pending and not isinstance(e, KeyboardInterrupt):
            _restore(previous, held)
            checkpoint()  # raised inside this handler: e becomes its __context__
        raise
    finally:
        _restore(previous, held)
    checkpoint()


def _restore(previous: dict[int, Any], held: list[int]) -> None:
    import signal

    for s in held:
        signal.signal(s, previous[s])


def _caused_by_interrupt(e: BaseException) -> bool:
    """Whether a Ctrl-C or SIGTERM (KeyboardInterrupt) lies in e's chain of causes. One that lands
    inside an import comes back wrapped: as ImportError from a C extension (OCP), as RuntimeError
    ("Error calling __set_name__") when it interrupts a class body."""
    seen: set[int] = set()
    cur: BaseException | None = e
    while cur is not None and id(cur) not in seen:
        if isinstance(cur, KeyboardInterrupt):
            return True
        seen.add(id(cur))
        cur = cur.__cause__ or cur.__context__
    return False


class _Interrupted(BaseException):
    """Ctrl-C inside a command, carried past click (which would print a blank line and "Aborted!")."""


class FabpatGroup(click.Group):
    """A click group whose errors are one line on stderr and exit code 2."""

    def invoke(self, ctx: click.Context) -> Any:
        """Run the command; a Ctrl-C inside it leaves click as :class:`_Interrupted` (see :meth:`main`)."""
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as e:
            raise _Interrupted from e
        except Exception as e:
            if _caused_by_interrupt(e):
                raise _Interrupted from e
            raise

    def main(self, *args: Any, **kwargs: Any) -> Any:  # noqa: D102 - click's signature
        """Run the group; usage errors and :class:`FabpatError` become one stderr line and exit code 2."""
        kwargs["standalone_mode"] = False
        try:
            from fabpat.io import input_scope

            _NOTICES.clear()
            with _sigterm_unwinds(), input_scope():  # no output of the command may replace its inputs
                rv = super().main(*args, **kwargs)
            from fabpat.stdout import check_stdout

            check_stdout()  # what was printed all arrived (a full disk, /dev/full, `ulimit -f`): else one line
            for note in _NOTICES:
                click.echo(f"fabpat: warning: {note}", err=True)
        except click.exceptions.NoArgsIsHelpError as e:  # `fabpat` alone: the help, not a one-line error
            click.echo(e.ctx.get_help() if e.ctx is not None else e.format_message())
            sys.exit(0)
        except click.exceptions.UsageError as e:
            _fail(e.format_message())
        except FabpatError as e:
            _fail(str(e))
        except OSError as e:  # a file system refusal no check foresaw: still one line, not a traceback
            from fabpat.stdout import stdout_error

            named = stdout_error(e)  # no room, and no file named: the printed output (files name themselves)
            _fail(str(named) if named else f"{e.filename}: {e.strerror}" if e.filename and e.strerror else str(e))
        except MemoryError:  # past every size estimate (they are estimates): still one line, not a traceback
            _fail("out of memory: the work asked for more memory than this process may use (free memory, a "
                  "container's or `ulimit -v` limit); use a coarser --h, a smaller input or a machine with more memory")
        except _Interrupted:
            _interrupted()
        except click.exceptions.Abort as e:
            if _TERMINATED or isinstance(e.__cause__, KeyboardInterrupt):
                _interrupted()
            click.echo("fabpat: aborted", err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


def _interrupted() -> None:
    """One line and 128 + the signal: 130 for Ctrl-C (SIGINT), 143 for SIGTERM (:func:`interrupt_status`)."""
    from fabpat.interrupts import forget_interrupt

    forget_interrupt()
    word, code = interrupt_status()
    click.echo(f"fabpat: {word}", err=True)
    sys.exit(code)


def _fail(message: str) -> None:
    line = " ".join(message.split())
    notes = "".join(f" (note: {n})" for n in _NOTICES)  # a deprecated alias: still one line
    click.echo(f"fabpat: error: {line}{notes}", err=True)
    sys.exit(2)


@click.group(cls=FabpatGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="fabpat")
def cli() -> None:
    """Design, simulate and export fabricable geometric patterns for flat mechanical metamaterials."""


# Each module under fabpat/cli/ exposes COMMANDS; one line here adds a module's commands.
_COMMAND_MODULES = ("library_cmds", "simulate_cmds", "export_cmds", "catalog_cmds", "assembly_cmds", "design_cmds",
                    "predict_cmds")


def _register() -> None:
    import importlib

    for name in _COMMAND_MODULES:
        for cmd in importlib.import_module(f"fabpat.cli.{name}").COMMANDS:
            cli.add_command(cmd)


_register()


def main() -> None:
    """Console entry point of the ``fabpat`` command."""
    cli.main(prog_name="fabpat")
