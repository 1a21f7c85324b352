"""The kit's output folder: what ``assemble`` may replace, and the swap that replaces it.

A kit is written into a temporary folder beside ``--out`` and renamed to it at the very end
(:func:`swap_in`). An existing ``--out`` is replaced only when fabpat demonstrably wrote everything
in it (:func:`foreign_entries`): its ``manifest.json`` is a JSON object written by ``fabpat assemble``
whose ``sha256`` lists every file of the folder with its SHA-256 digest, and the folder holds
nothing else (no other file, folder, link or special file) and no listed file has changed since. A
file the user put there or edited, or an earlier kit from a fabpat that did not record digests,
makes ``assemble`` refuse with one line naming it, so nothing of the user's is deleted. A failed
swap puts the earlier folder back and leaves no temporary folder behind.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from fabpat.errors import ExportError
from fabpat.io import temp_prefix

MANIFEST = "manifest.json"
GENERATOR = "fabpat assemble"
#: largest manifest.json read back (bytes): a kit's is a few kB; a larger one is not ours
MAX_MANIFEST_BYTES = 4 * 1024 * 1024
_CHUNK = 1 << 20


def sha256(path: Path) -> str:
    """Hex SHA-256 digest of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(_CHUNK), b""):
            h.update(block)
    return h.hexdigest()


def digests(folder: Path, files: list[str]) -> dict[str, str]:
    """{relative path: SHA-256} of the kit's ``files`` in ``folder`` (the manifest's ``sha256``)."""
    return {name: sha256(folder / name) for name in files}


def _entries(folder: Path) -> tuple[list[str], list[str]]:
    """(regular files, anything else) under ``folder``, as paths relative to it; links are never followed."""
    files: list[str] = []
    other: list[str] = []
    for root, dirs, names in os.walk(folder, followlinks=False):
        base = Path(root)
        for d in list(dirs):
            if (base / d).is_symlink():  # os.walk lists a link to a folder as a folder
                other.append(str((base / d).relative_to(folder)))
                dirs.remove(d)
        for n in names:
            p = base / n
            rel = str(p.relative_to(folder))
            (files if p.is_file() and not p.is_symlink() else other).append(rel)
    return files, other


def _manifest_digests(out: Path) -> dict[str, str] | str:
    """The manifest's {file: digest}, or why ``out`` is not a kit fabpat can recognise (one phrase)."""
    path = out / MANIFEST
    if not path.is_file() or path.is_symlink():
        return f"it has no {MANIFEST} written by `fabpat assemble`"
    try:
        if path.stat().st_size > MAX_MANIFEST_BYTES:
            return f"its {MANIFEST} is larger than any kit's"
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return f"its {MANIFEST} cannot be read as JSON"
    if not isinstance(data, dict) or data.get("generator") != GENERATOR:
        return f"its {MANIFEST} is not one written by `fabpat assemble`"
    listed = data.get("sha256")
    if not isinstance(listed, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in listed.items()):
        return (f"its {MANIFEST} lists no file digests (an earlier fabpat's kit, or edited), so fabpat cannot tell "
                "its own files from yours")
    return listed


def foreign_entries(out: Path) -> str | None:
    """Why ``out`` may not be replaced (one phrase naming the first file in the way), or None if it may:
    it does not exist, is an empty folder, or holds exactly the files its manifest lists, unchanged."""
    if not out.exists() and not out.is_symlink():
        return None
    if out.is_symlink():
        return "it is a symbolic link (the kit would replace the link, not the folder it points to)"
    if not out.is_dir():
        return "it is not a folder"
    files, other = _entries(out)
    if not files and not other:
        return None
    listed = _manifest_digests(out)
    if isinstance(listed, str):
        return listed
    if other:
        return f"it holds {other[0]}, which is not a regular file fabpat wrote"
    for name in sorted(files):
        if name == MANIFEST:
            continue
        if name not in listed:
            return f"it holds {name}, which fabpat did not write"
        try:
            same = sha256(out / name) == listed[name]
        except OSError:
            same = False
        if not same:
            return f"{name} has changed since fabpat wrote it"
    return None


def check_out(out: Path) -> None:
    """Raise :class:`ExportError` unless ``out`` can receive a kit (before any work is done): its parent
    is a writable folder, it is not the current folder or one above it (the swap renames ``out``), and
    :func:`foreign_entries` finds nothing in the way."""
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise ExportError(f"cannot write {out}: folder {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise ExportError(f"cannot write {out}: folder {parent} is not writable")
    here = Path.cwd().resolve()
    target = out.resolve()
    if out.name in ("", ".", "..") or target == here or target in here.parents:
        raise ExportError(f"--out {out} is the current folder or one above it, which the kit cannot replace: give the "
                          "name of a new folder")
    why = foreign_entries(out)
    if why is not None:
        raise ExportError(f"--out {out} exists and is not an earlier `fabpat assemble` output as it was written: "
                          f"{why}; remove or move that, or choose a new folder")


def swap_in(tmp: Path, out: Path, in_the_way: Callable[[Path], str | None] = foreign_entries) -> None:
    """Rename the finished ``tmp`` folder to ``out``, replacing an earlier output only now (checked again
    with ``in_the_way``, :func:`foreign_entries` for a kit, in case a file appeared while it was built).
    On any failure the earlier folder is back at ``out``, the set-aside folder is removed and the error
    raised (the caller removes ``tmp``)."""
    why = in_the_way(out)
    if why is not None:
        raise ExportError(f"--out {out} changed while the kit was built and {why}: nothing was replaced")
    if not out.exists():
        os.replace(tmp, out)
        return
    aside = Path(tempfile.mkdtemp(prefix=temp_prefix(out.name), suffix=".part", dir=out.parent))
    try:
        os.replace(out, aside / out.name)
    except BaseException:
        with contextlib.suppress(OSError):
            aside.rmdir()
        raise
    try:
        os.replace(tmp, out)
    except BaseException:
        with contextlib.suppress(OSError):
            os.replace(aside / out.name, out)  # the earlier kit goes back
        if not (aside / out.name).exists():
            with contextlib.suppress(OSError):
                aside.rmdir()
        raise
    shutil.rmtree(aside, ignore_errors=True)


def write_folder(out: Path, write: Callable[[Path], list[str]],
                 in_the_way: Callable[[Path], str | None] = foreign_entries) -> list[str]:
    """Write a folder of outputs into ``out`` all or nothing: ``write(tmp)`` fills a fresh temporary folder
    beside ``out`` and returns its files (relative paths); the folder gets the user's usual permissions and is
    swapped in (:func:`swap_in`, refusing an ``out`` that holds what ``in_the_way`` names). Returns the files.
    An :class:`OSError` (a full disk, a read-only parent) becomes one :class:`ExportError` naming ``out``; on
    any error the temporary folder is removed and ``out`` is untouched."""
    from fabpat.io import remove_stale_temps, write_error

    parent = out.parent if str(out.parent) else Path(".")
    remove_stale_temps(parent)  # the temporary folders of a killed earlier run
    try:
        tmp = Path(tempfile.mkdtemp(prefix=temp_prefix(out.name), suffix=".part", dir=parent))
    except OSError as e:  # a read-only or immutable parent: one line naming --out
        raise write_error(out, e) from e
    try:
        files = write(tmp)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o777 & ~mask)  # mkdtemp makes 0700 folders
        swap_in(tmp, out, in_the_way)
    except OSError as e:  # a full disk while writing: one line naming --out, not a temporary file
        shutil.rmtree(tmp, ignore_errors=True)
        raise write_error(out, e) from e
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return files


def write_kit(out: Path, write: Callable[[Path], tuple[list[str], dict[str, object]]]) -> list[str]:
    """A kit written by :func:`write_folder`: ``write(tmp)`` writes the kit's files and returns them with the
    manifest, whose ``sha256`` entry (kept in its place, or added last) gets their digests before
    ``manifest.json`` is written. Returns the files (without the manifest)."""

    def with_manifest(tmp: Path) -> list[str]:
        files, manifest = write(tmp)
        manifest["sha256"] = digests(tmp, files)
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
        return files

    return write_folder(out, with_manifest)
