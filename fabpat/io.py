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
* Only regular files are replaced: a target (or link target) that exists and is a directory, a FIFO,
  a device or a socket is refused, checked again just before the rename, so that ``/dev/null`` or a
  named pipe never becomes a regular file (as root a rename over ``/dev/null`` succeeds). A path
  ending in ``/`` names a folder and is refused as a file output. fabpat writes no output to a device:
  what a command prints on stdout (``fabpat show`` without ``--svg``) is the way to stream.
* Input files declared to :func:`check_distinct` must be regular files (a FIFO would hang the read,
  ``/dev/zero`` would read until memory runs out); :func:`read_input` reads one with a size bound.
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
import stat
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from fabpat.errors import ExportError, WriteFailed

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


def file_kind(mode: int) -> str:
    """What a ``st_mode`` is, for messages: ``"a regular file"``, ``"a directory"``, ``"a FIFO (named
    pipe)"``, ``"a character device"``, ``"a block device"``, ``"a socket"``."""
    kinds = ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
    return next((text for test, text in kinds if test(mode)), "not a regular file")


def special_kind(path: str | os.PathLike[str]) -> str | None:
    """:func:`file_kind` of what ``path`` names (links followed) if it exists and is not a regular file;
    None if it is a regular file or does not exist. ``os.stat`` opens nothing, so a FIFO cannot hang it."""
    try:
        mode = os.stat(path).st_mode
    except OSError:  # missing (or a dangling link, or unreadable): not known to be special here
        return None
    return None if stat.S_ISREG(mode) else file_kind(mode)


def check_file_name(path: str | os.PathLike[str], what: str = "cannot write") -> None:
    """:class:`ExportError` if ``path`` names a folder by its spelling: it ends in ``/`` (``a.vtu/``),
    ``/.`` or ``/..``, or is empty. ``Path("a.vtu/")`` drops the slash, so the raw text is checked."""
    raw = os.fspath(path)
    if isinstance(raw, bytes):
        raw = os.fsdecode(raw)
    seps = tuple(s for s in (os.sep, os.altsep) if s)
    if not raw or raw.endswith(seps) or os.path.basename(raw) in ("", ".", ".."):
        raise ExportError(f"{what} {raw!r}: a path ending in {os.sep!r} (or '.', '..') names a folder, "
                          "not a file: give a file name")


def check_suffix(path: str | os.PathLike[str], suffixes: Iterable[str], what: str) -> Path:
    """``path`` as a Path if its suffix (any case) is one of ``suffixes``; else :class:`ExportError`
    naming ``what`` (the option or file kind) and the valid suffixes, so that VTU XML never lands in a
    ``.txt`` or a PNG in an ``.svg``. A path that names a folder (``a.vtu/``) is refused too
    (:func:`check_file_name`)."""
    valid = [s.lower() for s in suffixes]
    check_file_name(path, what)
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
    An input that exists must be a regular file (:func:`check_input`).
    """
    if inputs:
        declared = tuple((k, os.fspath(v)) for k, v in inputs.items() if v is not None)
        for name, src in declared:
            check_input(src, name)
        _INPUTS.set(_INPUTS.get() + declared)
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


def check_input(path: str | os.PathLike[str], name: str) -> None:
    """:class:`ExportError` if the input ``path`` (``name``: how the command calls it, ``"SPEC"``,
    ``"--db"``) exists and is not a regular file, before anything opens it: reading a FIFO waits for a
    writer for ever, ``/dev/zero`` never ends, and a catalog written over a device replaces it (as
    root). A missing input is left to the command (a catalog not made yet is created)."""
    kind = special_kind(path)
    if kind is not None:
        via = f" (a symbolic link to {os.path.realpath(path)})" if os.path.islink(path) else ""
        raise ExportError(f"{name} {os.fspath(path)}{via} is {kind}, not a regular file: give the path of a file")


#: bytes: the default bound of :func:`read_input` (a spec or a cache is kilobytes; 64 MiB is no file of ours)
MAX_INPUT_BYTES = 64 * 1024 * 1024


def read_input(path: str | os.PathLike[str], name: str, max_bytes: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of the input file ``path``, refusing (:class:`ExportError`, naming ``name``) anything
    that is not a regular file (checked before opening, and on the opened file, with ``O_NONBLOCK`` so
    a FIFO swapped in meanwhile cannot hang the open) or holds more than ``max_bytes``. ``OSError``
    (missing, unreadable) is left to the caller, which knows what a missing input means."""
    check_input(path, name)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    with os.fdopen(fd, "rb") as f:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise ExportError(f"{name} {os.fspath(path)} is {file_kind(mode)}, not a regular file: give the path "
                              "of a file")
        data = f.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ExportError(f"{name} {os.fspath(path)} is larger than {max_bytes} bytes: not a file fabpat wrote "
                          "or reads")
    return data


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
    """One-line :class:`ExportError` for an ``OSError`` while writing ``target`` (names a full disk and
    the file size limit)."""
    if e.errno in _DISK_FULL:
        t = Path(target)
        folder = t if t.is_dir() else t.parent if str(t.parent) else Path(".")
        return ExportError(f"cannot write {target}: the disk is full ({e.strerror or e}); free space in "
                           f"{folder} and run again")
    if e.errno == errno.EFBIG:  # explained once (writer_failed may have said it already)
        why = e.strerror if e.strerror and "ulimit -f" in e.strerror else too_large_text(e.strerror)
        return ExportError(f"cannot write {target}: {why}")
    return ExportError(f"cannot write {target}: {e.strerror or e}")


def file_size_limit() -> int | None:
    """Bytes a file this process writes may hold (``ulimit -f``, RLIMIT_FSIZE), None if unlimited."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    except (ImportError, OSError, ValueError):
        return None
    return None if limit == resource.RLIM_INFINITY else int(limit)


#: errors of a write that say where the data went cannot take it (a full disk or device, the size limit)
NO_ROOM = (*_DISK_FULL, errno.EFBIG)


def too_large_text(strerror: str | None) -> str:
    """The text of EFBIG: the file reached the process's file size limit (the shell's ``ulimit -f``)."""
    limit = file_size_limit()
    cap = f" of {limit} bytes" if limit is not None else ""
    return (f"{strerror or os.strerror(errno.EFBIG)}: it reached the file size limit{cap} (ulimit -f); raise "
            "the limit or write elsewhere")




#: bytes: a folder with less free space than this after a failed write is called full (a failed writer's
#: partial file has used up what was left; an honest "the disk is full" needs the space to be gone)
FULL_BELOW = 256 * 1024


def writer_failed(path: str | os.PathLike[str], what: str, cause: OSError | None = None) -> WriteFailed:
    """The error to raise when a writer could not write ``path``.

    With ``cause`` (the writer's own ``OSError``), its ``errno`` and text. Without (OCCT's STEP and STL
    writers and rhino3dm return a failure status, no ``errno``): ``ENOSPC`` if the file system of
    ``path`` has less than :data:`FULL_BELOW` bytes free for the user (``os.statvfs``), so the message
    says "the disk is full" only when it is; ``EFBIG`` if the partial file reached the process's file size
    limit (``ulimit -f``); otherwise ``EIO`` with ``what`` as its text.
    """
    if cause is not None:
        why = too_large_text(cause.strerror) if cause.errno == errno.EFBIG else cause.strerror or what
        return WriteFailed(cause.errno, why, os.fspath(path))
    limit = file_size_limit()
    with contextlib.suppress(OSError):
        if limit is not None and os.path.getsize(path) >= limit:  # the writer stopped at `ulimit -f`
            return WriteFailed(errno.EFBIG, f"{what}: {too_large_text(None)}", os.fspath(path))
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
    """The path to replace (a symbolic link's target), if the path names a file (not ``a/``), its
    folder exists and is writable, and it is absent or a regular file; :class:`ExportError` naming the
    path and what it is (a directory, a FIFO, a character device, …) otherwise."""
    check_file_name(path)
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.exists():
        raise ExportError(f"cannot write {p}: folder {folder} does not exist")
    if not folder.is_dir():
        raise ExportError(f"cannot write {p}: {folder} is not a folder")
    if not os.access(folder, os.W_OK):
        raise ExportError(f"cannot write {p}: folder {folder} is not writable")
    real = _through_link(p)
    _refuse_special(p, real)
    return real


def _refuse_special(shown: Path, real: Path) -> None:
    """:class:`ExportError` if ``real`` (the file ``shown`` names, links followed) exists and is not a
    regular file: fabpat never renames over a directory, a FIFO, a device or a socket."""
    kind = special_kind(real)
    if kind is not None:
        via = f" (a symbolic link to {real})" if real != shown else ""
        raise ExportError(f"cannot write {shown}{via}: it is {kind}, not a regular file; fabpat replaces only "
                          "regular files: give another path")


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
            if hit is None and e.errno in NO_ROOM and targets:  # a write's error names no file: its target
                hit = targets[0] if len(targets) == 1 else (targets[0].parent if str(targets[0].parent) else Path("."))
            if hit is None:
                raise
            raise write_error(hit, e) from e
        mode = file_mode()  # mkstemp makes 0600 files; give them the user's usual permissions
        for shown, t in zip(paths, targets, strict=True):  # again: a FIFO may have appeared meanwhile
            _refuse_special(Path(shown), t)
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
