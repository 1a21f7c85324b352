"""One error hierarchy for the whole package.

The library raises; only the CLI turns an error into a one-line message and exit code 2.
"""


class FabpatError(Exception):
    """Base of every error fabpat raises on purpose."""


class PatternError(FabpatError, ValueError):
    """A bad pattern ID, polygon or depth."""


class GeometryError(FabpatError):
    """An outline that is not closed, not simple, or cannot be filleted."""


class ExportError(FabpatError):
    """A file that cannot be written in the requested format."""


class SolverError(FabpatError):
    """A simulation that did not converge or is ill-posed."""


class SpecError(FabpatError, ValueError):
    """An invalid assembly spec."""


class RangeError(FabpatError, ValueError):
    """A number that is not finite or outside its physical range, or work too large to start."""


class CatalogError(FabpatError, ValueError):
    """A catalog file that is missing, not a fabpat catalog, from an incompatible schema or holding a
    bad value; a bad filter or query argument (a ``ValueError`` too, as before it was one of these)."""


class WriteFailed(ExportError, OSError):
    """A writer could not write a file: an :class:`ExportError` for callers, and an ``OSError`` (with
    ``errno`` and ``filename``) so that :func:`fabpat.io.atomic_outputs` names the target instead of its
    temporary file, and a full disk as such."""

    def __str__(self) -> str:
        return f"cannot write {self.filename}: {self.strerror}"
