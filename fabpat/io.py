"""Atomic file output: a file appears under its name only when it is complete.

Every writer in fabpat goes through :func:`atomic_outputs`, so an error (bad input found late, a
crash, Ctrl-C, SIGTERM) never leaves a partial or half-written file behind.

* Temporary files are named ``.<stem>.<pid>.<random>.part<suffix>`` next to their target. They are
  removed when the block fails or is interrupted (SIGINT; SIGTERM once the CLI turned it into an
  exception); a run killed outright (SIGKILL, power loss) leaves them, and the next run writing into
  that folder removes every such file whose process is gone (:func:`remove_stale_temps`).
* Two outputs of one block naming the same file are refused (:func:`check_distinct`), for every
  command at once; so is an output that is one of the command's input files (a catalog, a spec),
  declared with :func:`input_scope` / ``check_distinct(..., inputs=...)``, also through links.
* A target that is a symbolic link is written *through*: the link stays and the file it points to
  is replaced (atomically, in the link target's folder). A dangling link is refused.
* An output folder created by :func:`output_folder` is removed again when nothing could be written
  into it (a full disk, an error), so a failed command leaves no empty folder.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import re
import secrets
import shutil
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from fabpat.errors import ExportError

#: ``.<name>.<pid>.<8 random characters>.part[<suffix>]``: the temporary names of fabpat (see temp_prefix)
_TEMP_NAME = re.compile(r"^\..*\.(?P<pid>[0-9]+)\.[A-Za-z0-9_]{8}\.part(\.[^/]*)?$")
_DISK_FULL = (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC))  # no space, or over the quota


def temp_prefix(name: str) -> str:
    """Prefix of a temporary file or folder for ``name``: ``.<name>.<pid>.`` (see :func:`remove_stale_temps`)."""
    return f".{name}.{os.getpid()}."


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: another user's live process
        return True
    return True


def remove_stale_temps(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove fabpat's temporary files and folders in ``folder`` whose writing process is gone.

    Only names of the form ``.<name>.<pid>.<8 characters>.part[<suffix>]`` are touched, and only when
    no process ``pid`` exists on this machine (a live writer's files are kept). Returns what was removed.
    """
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP_NAME.match(entry.name)
        if m is None or _alive(int(m["pid"])):
            continue
        try:
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
            removed.append(Path(entry.path))
        except OSError:  # raced with another cleaner, or not ours to remove: leave it
            pass
    return removed


def check_suffix(path: str | os.PathLike[str], suffixes: Iterable[str], what: str) -> Path:
    """``path`` as a Path if its suffix (any case) is one of ``suffixes``; else :class:`ExportError`
    naming ``what`` (the option or file kind) and the valid suffixes, so that VTU XML never lands in a
    ``.txt`` or a PNG in an ``.svg``."""
    valid = [s.lower() for s in suffixes]
    p = Path(path)
    if p.suffix.lower() not in valid:
        raise ExportError(f"{what} must end in {' or '.join(valid)}, got {os.fspath(path)!r}")
    return p


#: the input files of the running command: (how the command names it, path); see input_scope
_INPUTS: contextvars.ContextVar[tuple[tuple[str, str], ...]] = contextvars.ContextVar("fabpat_inputs", default=())


@contextlib.contextmanager
def input_scope() -> Iterator[None]:
    """A block (one CLI command) whose declared input files no output may replace: inputs declared with
    ``check_distinct(..., inputs=...)`` inside it are forgotten when it ends."""
    token = _INPUTS.set(())
    try:
        yield
    finally:
        _INPUTS.reset(token)


def _same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two paths name one file: the same path after following symbolic links, or one file
    under two names (a hard link)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): not the same file
        return False


def check_distinct(paths: Iterable[str | os.PathLike[str]],
                   inputs: Mapping[str, str | os.PathLike[str] | None] | None = None) -> None:
    """Raise :class:`ExportError` if two of ``paths`` name the same file (after following links), or if
    one of them is an input file of the command (the same file, also through a symbolic or hard link)
    or a folder holding one (an output folder is replaced whole: ``assemble --out``).

    ``inputs`` maps how the command names an input (``"--db"``, ``"SPEC"``) to its path (None: not
    given); they are remembered for the rest of the :func:`input_scope` (the CLI command), so every
    later :func:`atomic_outputs` refuses to replace them too — also a file inside an output folder.
    """
    if inputs:
        _INPUTS.set(_INPUTS.get() + tuple((k, os.fspath(v)) for k, v in inputs.items() if v is not None))
    seen: dict[str, Path] = {}
    for p in paths:
        for name, src in _INPUTS.get():
            if _same_file(p, src):
                same = f"{p}" if os.path.abspath(p) == os.path.abspath(src) else f"{p} (the same file as {src})"
                raise ExportError(f"the output {same} is the input {name} of this command: writing it would "
                                  "replace the input; give the output another path")
            if Path(os.path.realpath(src)).is_relative_to(os.path.realpath(p)):  # a folder output replaced whole
                raise ExportError(f"the output {p} holds the input {name} ({src}): writing it would replace the "
                                  "input; give the output another path")
        key = os.path.realpath(p)
        if key in seen:
            same = f"{p}" if str(seen[key]) == str(p) else f"{seen[key]} and {p}"
            raise ExportError(f"two outputs would write the same file ({same}): give each output its own path")
        seen[key] = Path(p)


def _through_link(p: Path) -> Path:
    """The file a symbolic link points to (the link is kept and written through); ``p`` otherwise."""
    if not p.is_symlink():
        return p
    real = Path(os.path.realpath(p))
    if not real.parent.is_dir():
        raise ExportError(f"cannot write {p}: it is a symbolic link to {real}, whose folder does not exist")
    if not real.exists():
        raise ExportError(f"cannot write {p}: it is a dangling symbolic link (to {real}); remove it or "
                          "create the file it points to")
    return real


def write_error(target: str | os.PathLike[str], e: OSError) -> ExportError:
    """One-line :class:`ExportError` for an ``OSError`` while writing ``target`` (names a full disk)."""
    if e.errno in _DISK_FULL:
        t = Path(target)
        folder = t if t.is_dir() else t.parent if str(t.parent) else Path(".")
        return ExportError(f"cannot write {target}: the disk is full ({e.strerror or e}); free space in "
                           f"{folder} and run again")
    return ExportError(f"cannot write {target}: {e.strerror or e}")


#: bytes: a folder with less free space than this after a failed write is called full (a failed writer's
#: partial file has used up what was left; an honest "the disk is full" needs the space to be gone)
FULL_BELOW = 256 * 1024


class WriteFailed(ExportError, OSError):
    """A writer could not write a file: an :class:`ExportError` for callers, and an ``OSError`` (with
    ``errno`` and ``filename``) so that :func:`atomic_outputs` names the target instead of its
    temporary file, and a full disk as such."""

    def __str__(self) -> str:
        return f"cannot write {self.filename}: {self.strerror}"


def writer_failed(path: str | os.PathLike[str], what: str, cause: OSError | None = None) -> WriteFailed:
    """The error to raise when a writer could not write ``path``.

    With ``cause`` (the writer's own ``OSError``), its ``errno`` and text. Without (OCCT's STEP and STL
    writers and rhino3dm return a failure status, no ``errno``): ``ENOSPC`` if the file system of
    ``path`` has less than :data:`FULL_BELOW` bytes free for the user (``os.statvfs``), so the message
    says "the disk is full" only when it is; otherwise ``EIO`` with ``what`` as its text.
    """
    if cause is not None:
        return WriteFailed(cause.errno, cause.strerror or what, os.fspath(path))
    folder = os.path.dirname(os.fspath(path)) or "."
    try:
        st = os.statvfs(folder)
        full = st.f_bavail * st.f_frsize < FULL_BELOW
    except OSError:
        full = False
    if full:
        return WriteFailed(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))
    return WriteFailed(errno.EIO, what, os.fspath(path))


def check_writable(path: str | os.PathLike[str]) -> Path:
    """The path, if its folder exists and is writable; :class:`ExportError` otherwise."""
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.exists():
        raise ExportError(f"cannot write {p}: folder {folder} does not exist")
    if not folder.is_dir():
        raise ExportError(f"cannot write {p}: {folder} is not a folder")
    if not os.access(folder, os.W_OK):
        raise ExportError(f"cannot write {p}: folder {folder} is not writable")
    if p.is_dir():
        raise ExportError(f"cannot write {p}: it is a directory")
    return _through_link(p)


def check_output_folder(path: str | os.PathLike[str], option: str = "--out") -> Path:
    """An output folder that may exist already (as a folder) and whose parent must exist.

    Like a file output, a folder is not created with missing parents: a typo in a path should not
    build a tree of folders somewhere. :class:`ExportError` otherwise.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ExportError(f"{option} {p} exists and is not a folder")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ExportError(f"cannot write {p}: folder {parent} does not exist")
    return p


@contextlib.contextmanager
def output_folder(path: str | os.PathLike[str], option: str = "--out") -> Iterator[Path]:
    """Create the output folder ``path`` (if missing) for the block; remove it again if the block fails
    and the folder is still empty, so a failed command (a full disk, an error, Ctrl-C) leaves no empty
    folder. An existing folder is kept as it was. :class:`ExportError` as :func:`check_output_folder`.
    """
    p = check_output_folder(path, option)
    created = not p.exists()
    try:
        p.mkdir(exist_ok=True)
    except OSError as e:
        raise ExportError(f"cannot create folder {p}: {e.strerror or e}") from e
    try:
        yield p
    except BaseException:
        if created:
            _remove_created_folder(p)
        raise


def _remove_created_folder(p: Path) -> None:
    """Remove stale temporaries and the folder ``p`` if then empty, finishing even if Ctrl-C or SIGTERM
    arrives meanwhile (re-raised at the end, as :func:`remove_all`): a third Ctrl-C in quick succession
    left the created folder behind."""
    interrupted: BaseException | None = None
    for _ in range(3):  # bounded, unlike remove_all's loop: a fault that is not an interrupt must not spin
        try:
            with contextlib.suppress(OSError):
                remove_stale_temps(p)
                p.rmdir()  # only if empty: never remove what someone else put there meanwhile
            break
        except BaseException as e:  # noqa: BLE001 - finish the cleanup first, then re-raise
            interrupted = interrupted or e
    if interrupted is not None:
        raise interrupted


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def file_mode() -> int:
    """Permissions of a new file under the user's umask (``mkstemp`` alone makes 0600 files)."""
    return 0o666 & ~_umask()


@contextlib.contextmanager
def atomic_outputs(*paths: str | os.PathLike[str]) -> Iterator[list[Path]]:
    """Yield temporary paths next to each target; rename them all only if the block succeeds.

    >>> with atomic_outputs("a.svg", "b.png") as (tmp_svg, tmp_png):
    ...     tmp_svg.write_text(...)   # doctest: +SKIP
    """
    check_distinct(paths)
    targets = [check_writable(p) for p in paths]
    for folder in dict.fromkeys(t.parent for t in targets):
        remove_stale_temps(folder if str(folder) else ".")
    temps: list[Path] = []
    try:
        for t in targets:
            _new_temp(t, temps)
        try:
            yield temps
        except OSError as e:  # a writer's own OSError (a full disk): name the target, not the temp file
            by_temp = {os.fspath(x): t for x, t in zip(temps, targets, strict=True)}
            hit = by_temp.get(os.fspath(e.filename)) if isinstance(e.filename, str | os.PathLike) else None
            if hit is None and e.errno in _DISK_FULL:
                hit = targets[0] if len(targets) == 1 else (targets[0].parent if str(targets[0].parent) else Path("."))
            if hit is None:
                raise
            raise write_error(hit, e) from e
        mode = file_mode()  # mkstemp makes 0600 files; give them the user's usual permissions
        for tmp, t in zip(temps, targets, strict=True):
            try:
                os.chmod(tmp, mode)
                os.replace(tmp, t)
            except OSError as e:
                raise write_error(t, e) from e
    finally:
        remove_all(temps)


def _new_temp(target: Path, temps: list[Path]) -> None:
    """Create an empty temporary file next to ``target`` and list it in ``temps``.

    The name is listed *before* the file is created (``O_EXCL``, like :func:`tempfile.mkstemp`), so a
    Ctrl-C at any moment leaves no file that the cleanup does not know about.
    """
    folder = target.parent if str(target.parent) else Path(".")
    for _ in range(100):
        # keep the real suffix last: writers that pick the format from the suffix still work
        tmp = folder / f"{temp_prefix(target.stem)}{secrets.token_hex(4)}.part{target.suffix}"
        temps.append(tmp)
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
            return
        except FileExistsError:
            temps.pop()  # not ours
        except OSError as e:  # a folder that exists but takes no files (/proc, a read-only mount, …)
            temps.pop()
            raise write_error(target, e) from e
    raise ExportError(f"cannot write {target}: no free temporary name in {folder}")


def remove_all(paths: list[Path]) -> None:
    """Unlink every path (missing ones are fine), even if Ctrl-C or SIGTERM arrives meanwhile.

    An interruption during the cleanup is re-raised once every file is gone, so a second Ctrl-C
    cannot leave half of a thousand temporary files behind.
    """
    pending = list(paths)
    interrupted: BaseException | None = None
    while pending:
        try:
            while pending:
                with contextlib.suppress(OSError):
                    pending[-1].unlink()
                pending.pop()
        except BaseException as e:  # noqa: BLE001 - finish the cleanup first, then re-raise
            interrupted = interrupted or e
    if interrupted is not None:
        raise interrupted
