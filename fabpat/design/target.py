"""Design targets: what shape ``fabpat design`` should reach, read and checked before any work.

* **Strip target** (:class:`StripTarget`): a CSV of the arch's mid-line, header ``x,z``, in mm; x along
  the span from column 0's pin, z up, both pins at z = 0 (within :data:`END_TOLERANCE` of the span).
* **Closed-tiling targets** (:class:`ClosedTarget`): ``sphere``, ``ellipsoid:A,B,C`` (axis ratios, each
  0.1 … 10: the range ``axis_ratio`` of :mod:`fabpat.design.ranges`) or a surface mesh file (``.obj``,
  ``.stl``, ``.ply``, read by trimesh; at least 4 faces with a positive area). They have no size: the plates
  fix it (:mod:`fabpat.design.surface`).
* **Open-tiling targets** (a :class:`ClosedTarget` too: the same fit and design, :mod:`fabpat.design.revolution`):
  ``cap:H`` for a ``hex-cap`` (a spherical cap of rim radius 1 and height H, in the range ``cap_height``) and
  ``revolution:R0,R1,…,Rk`` for a ``hex-tube`` (radii at equal steps along an axis of length 1, each in the range
  ``profile_radius``; 2 to :data:`MAX_RADII` of them). :data:`OPEN_TARGETS` says which tiling takes which.

A path that exists is a file, whatever its name (a CSV called ``sphere`` or ``ellipsoid-arch.csv`` is a
strip target); a folder is not (a folder ``sphere`` left by ``--out sphere`` leaves the keyword alone). A
file is read only if it is a regular file (a FIFO or a device is refused unopened) of at most
:data:`MAX_CSV_BYTES` (a CSV) or :data:`fabpat.assembly.surface.mesh_tiling.MAX_MESH_BYTES` (a mesh, the bound of a
tiling's mesh file), through :func:`fabpat.io.read_input`. Every problem is a :class:`TargetError` whose one
line names the target and what is expected, before any solve.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import FabpatError

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    from fabpat.design.surface import Implicit, SurfaceFit

Arr = NDArray[np.float64]

#: both ends of a strip target must lie within this fraction of the span of z = 0 (the pins' height):
#: 0.5 % is the accuracy the design aims at (docs/design.md), so a target whose pins are off by more
#: cannot be met even in principle
END_TOLERANCE = 0.005
#: surface mesh files a closed-tiling target may be
MESH_SUFFIXES = (".obj", ".stl", ".ply")
#: the named closed-tiling targets
CLOSED_NAMES = ("sphere", "ellipsoid:A,B,C")
#: the open tilings' targets: {target kind: (the tiling kind that takes it, its syntax)}
OPEN_TARGETS = {"cap": ("hex-cap", "cap:H"), "revolution": ("hex-tube", "revolution:R0,R1,…,Rk")}
#: most radii of a revolution target (a profile finer than the tube's rings of plates is not reachable)
MAX_RADII = 50
#: largest strip target file read (bytes): a mid-line of some 50 000 points; the design compares it column by
#: column, and a 200 MB file read whole ran out of memory instead of being refused
MAX_CSV_BYTES = 1024 * 1024
#: what a strip target file must look like (said in every refusal of one)
STRIP_FORMAT = "a CSV of the arch's mid-line with header x,z (mm; x from column 0's pin, z up, both ends at z = 0)"


class TargetError(FabpatError, ValueError):
    """A design target that cannot be read or is not a shape this version can design."""


@dataclass(frozen=True, eq=False)
class StripTarget:
    """A strip's target mid-line: ``x`` (n,) increasing and ``z`` (n,) heights, both mm, x = 0 at column
    0's pin, z = 0 at both pins; ``source`` names it in messages."""

    source: str
    x: Arr
    z: Arr

    @property
    def span(self) -> float:
        """Pin-to-pin distance (mm)."""
        return float(self.x[-1] - self.x[0])

    @property
    def arc_length(self) -> float:
        """Length of the polyline through the points (mm)."""
        return float(np.hypot(np.diff(self.x), np.diff(self.z)).sum())

    def scaled(self, factor: float) -> StripTarget:
        """The target scaled uniformly by ``factor`` about column 0's pin."""
        return StripTarget(self.source, (self.x - self.x[0]) * factor, self.z * factor)


#: latitude bands of a closed design's face groups when the target is not a sphere (docs/design.md)
BANDS = 3


@dataclass(frozen=True, eq=False)
class ClosedTarget:
    """A closed-tiling target: ``kind`` "sphere", "ellipsoid" (``axes`` the three ratios) or "mesh"
    (``path`` the surface file, ``mesh`` it read by trimesh); or an open tiling's, ``kind`` "cap" or
    "revolution" (``profile`` the cap's height, or the radii; :mod:`fabpat.design.revolution`)."""

    source: str
    kind: str
    axes: tuple[float, float, float] | None = None
    path: str | None = None
    mesh: trimesh.Trimesh | None = None
    profile: tuple[float, ...] | None = None

    @property
    def open(self) -> bool:
        """Whether the target is an open tiling's (:data:`OPEN_TARGETS`)."""
        return self.kind in OPEN_TARGETS

    @property
    def bands(self) -> int:
        """Latitude bands about the design axis that the face groups use: 1 for a round target (a sphere,
        or an ellipsoid with three equal ratios), else :data:`BANDS`."""
        if self.kind == "sphere" or (self.axes is not None and max(self.axes) - min(self.axes) <= 1e-12):
            return 1
        return BANDS

    def fit(self, P: Arr, axis: Arr) -> SurfaceFit:
        """The :class:`fabpat.design.surface.SurfaceFit` of nodes P (n, 3) mm; ``axis`` (3,) the design
        axis, where an ellipsoid's distinct axis starts."""
        from fabpat.design.surface import fit_to_ellipsoid, fit_to_mesh, fit_to_sphere

        if self.profile is not None:
            from fabpat.design.revolution import cap_profile, fit_to_profile, revolution_profile

            cap = self.kind == "cap"
            S = cap_profile(self.profile[0]) if cap else revolution_profile(self.profile)
            return fit_to_profile(P, S, axis, cap)
        if self.kind == "sphere":
            return fit_to_sphere(P)
        if self.kind == "ellipsoid":
            assert self.axes is not None
            return fit_to_ellipsoid(P, self.axes, axis)
        assert self.mesh is not None
        return fit_to_mesh(P, self.mesh, self.implicit)

    @cached_property
    def implicit(self) -> Implicit | None:
        """A watertight mesh target's smooth implicit surface (:func:`fabpat.design.surface.implicit_surface`,
        made once), so that its distances are smooth functions of the nodes; None for a named target or a mesh
        that is not watertight (its distances are to the nearest point of the mesh)."""
        from fabpat.design.surface import implicit_surface

        if self.mesh is None or not (self.mesh.is_watertight and self.mesh.is_winding_consistent):
            return None
        return implicit_surface(self.mesh)


def target_file(target: object) -> str | None:
    """The path of the file ``target`` names, or None for a name (``sphere``, ``ellipsoid:A,B,C``) or an
    array: what :func:`read_target` reads, and what a command declares as its TARGET input file (an output
    must not replace it). A path that exists and is not a folder is a file, whatever its name."""
    if not isinstance(target, str | os.PathLike) or isinstance(target, bytes):
        return None
    text = os.fspath(target)
    # a file, whatever its name: a CSV may be called "sphere"; a folder is none (`--out sphere` of a run before)
    if text and os.path.lexists(text) and not os.path.isdir(text):
        return text
    return None if _named(text) else text


def _named(text: str) -> bool:
    """Whether ``text`` is spelled as a named closed target (``sphere``, ``ellipsoid``, ``ellipsoid:…``)."""
    low = text.strip().lower()
    return low in ("sphere", "ellipsoid", *OPEN_TARGETS) or low.startswith(("ellipsoid:", *(f"{k}:" for k in
                                                                                          OPEN_TARGETS)))


def read_target(target: object) -> StripTarget | ClosedTarget:
    """The target named by ``target``: "sphere", "ellipsoid:A,B,C", a mesh file path, a CSV path, or an
    (n, 2) array of (x, z) points in mm. Raises :class:`TargetError` (one line)."""
    if isinstance(target, str | os.PathLike) and not isinstance(target, bytes):
        text = os.fspath(target)
        if target_file(text) is not None and os.path.lexists(text):
            if Path(text).suffix.lower() in MESH_SUFFIXES:
                return ClosedTarget(text, "mesh", path=text, mesh=_read_mesh(text))
            return _read_csv(Path(text))
        closed = _closed(text)
        if closed is not None:
            return closed
        return _read_csv(Path(text))
    try:
        pts = np.asarray(target, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TargetError(f"target must be a file name, 'sphere', 'ellipsoid:A,B,C' or an (n, 2) array of (x, z) "
                          f"points in mm, got {type(target).__name__}") from e
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise TargetError(f"a target array must have shape (n, 2) (columns x, z in mm), got {pts.shape}")
    return check_strip("(x, z) array", pts[:, 0], pts[:, 1])


def _closed(text: str) -> ClosedTarget | None:
    """The closed-tiling target ``text`` names (no file of that name exists), or None: then it is the name of a
    strip CSV."""
    low = text.strip().lower()
    if low == "sphere":
        return ClosedTarget("sphere", "sphere")
    for kind in OPEN_TARGETS:
        if low == kind or low.startswith(f"{kind}:"):
            return ClosedTarget(text, kind, profile=_profile(text, kind, low.removeprefix(kind).removeprefix(":")))
    if _named(text):  # an ellipsoid
        return ClosedTarget(text, "ellipsoid", _axes(text, low.removeprefix("ellipsoid").removeprefix(":")))
    if Path(text).suffix.lower() in MESH_SUFFIXES:  # a path that exists was read as a file (read_target)
        raise TargetError(f"cannot read target {text}: no such file")
    return None


def _axes(text: str, spec: str) -> tuple[float, float, float]:
    """The three axis ratios of ``ellipsoid:A,B,C`` (``spec`` the part after the colon), each in the range
    ``axis_ratio`` (:mod:`fabpat.design.ranges`); TargetError (one line) otherwise."""
    import fabpat.design.ranges  # noqa: F401 - registers axis_ratio's range
    from fabpat.validate import RANGES, check

    what = (f"target {text!r}: an ellipsoid is ellipsoid:A,B,C with three axis ratios in "
            f"{RANGES['axis_ratio'].describe()}, e.g. ellipsoid:1,1,1.15")
    try:
        axes = tuple(float(p) for p in spec.split(","))
    except ValueError:
        raise TargetError(what) from None
    if len(axes) != 3:
        raise TargetError(what)
    for name, a in zip("ABC", axes, strict=True):
        try:
            check("axis_ratio", a, f"axis ratio {name}", error=TargetError)
        except TargetError as e:
            raise TargetError(f"target {text!r}: {e} (ellipsoid:A,B,C, e.g. ellipsoid:1,1,1.15)") from None
    return axes[0], axes[1], axes[2]


def _profile(text: str, kind: str, spec: str) -> tuple[float, ...]:
    """The numbers of ``cap:H`` (one height in the range ``cap_height``) or ``revolution:R0,…,Rk`` (2 to
    :data:`MAX_RADII` radii in the range ``profile_radius``); ``spec`` the part after the colon. TargetError (one
    line) otherwise."""
    import fabpat.design.ranges  # noqa: F401 - registers the ranges
    from fabpat.validate import RANGES, check

    cap = kind == "cap"
    name = "cap_height" if cap else "profile_radius"
    what = (f"target {text!r}: a dome is cap:H, a spherical cap of rim radius 1 and height H in "
            f"{RANGES[name].describe()}, e.g. cap:0.5" if cap else
            f"target {text!r}: a surface of revolution is revolution:R0,R1,…,Rk, 2 to {MAX_RADII} radii at equal "
            f"steps along an axis of length 1, each in {RANGES[name].describe()}, e.g. revolution:0.45,0.5,0.45")
    try:
        values = tuple(float(p) for p in spec.split(","))
    except ValueError:
        raise TargetError(what) from None
    if len(values) != 1 if cap else not 2 <= len(values) <= MAX_RADII:
        raise TargetError(what)
    for v in values:
        try:
            check(name, v, "the height H" if cap else "a radius", error=TargetError)
        except TargetError as e:
            raise TargetError(f"{what}: {e}") from None
    return values


#: a mesh target whose thinnest principal extent (singular value of its centred vertices) is at most this
#: fraction of its widest is flat: no similarity transform puts a closed tiling onto it
FLAT_TARGET = 0.01


def _read_mesh(path: str) -> trimesh.Trimesh:
    """The surface of a mesh file (trimesh), or TargetError: unreadable, no faces, or degenerate."""
    import io

    from fabpat.assembly.surface.mesh_tiling import MAX_MESH_BYTES, check_scale

    data = _read_file(path, MAX_MESH_BYTES)  # first: refusing a FIFO or a device needs no trimesh
    import trimesh

    what = "a surface mesh (OBJ, STL or PLY with at least 4 triangles or polygons of positive area)"
    try:
        # read as written (trimesh's processing would drop a non-finite vertex and its faces unseen)
        m = trimesh.load(io.BytesIO(data), file_type=Path(path).suffix.lower()[1:], force="mesh", process=False)
        raw = np.asarray(getattr(m, "vertices", np.zeros((0, 3))), dtype=np.float64)
        finite = bool(np.isfinite(raw).all())
        if finite:  # a scale floating point cannot hold is refused by name before anything is computed from it
            check_scale(raw, np.asarray(getattr(m, "faces", np.zeros((0, 3), dtype=np.int64))).tolist(),
                        f"target {path}", what="the mesh", hint="", error=TargetError)
            m.process()
    except TargetError:
        raise
    except Exception as e:  # noqa: BLE001 - trimesh raises many kinds for a file that is no mesh
        # a reader's own message says what is wrong; Python's ("list index out of range") says nothing to a user
        internal = isinstance(e, IndexError | KeyError | TypeError | AttributeError) or not str(e)
        why = "the file holds no mesh that can be read" if internal else str(e).splitlines()[0][:80]
        raise TargetError(f"target {path} is not {what}: {why}") from None
    if not finite:
        raise TargetError(f"target {path}: a vertex is not finite (NaN or infinite coordinates)")
    faces = getattr(m, "faces", None)
    if faces is None or len(faces) < 4 or not float(getattr(m, "area", 0.0)) > 0:
        raise TargetError(f"target {path} is not {what}: it has {0 if faces is None else len(faces)} face(s)")
    if not isinstance(m, trimesh.Trimesh):  # force="mesh" makes one; anything else holds no surface
        raise TargetError(f"target {path} is not {what}: the file holds no mesh that can be read")
    V = np.asarray(m.vertices, dtype=np.float64)
    spread = np.linalg.svd(V - V.mean(axis=0), compute_uv=False)
    if spread[2] <= FLAT_TARGET * spread[0]:  # a closed tiling's shape cannot be fitted to a plane
        raise TargetError(f"target {path} is flat (its thinnest extent is {spread[2] / spread[0]:.2g} of its widest): "
                          "a closed tiling needs a surface that encloses a volume")
    return m


def _read_file(path: str | os.PathLike[str], max_bytes: int) -> bytes:
    """The bytes of the target file ``path`` (:func:`fabpat.io.read_input`: a regular file of at most
    ``max_bytes``); TargetError (one line) otherwise."""
    from fabpat.errors import ExportError
    from fabpat.io import read_input

    try:
        return read_input(path, "target", max_bytes)
    except ExportError as e:
        raise TargetError(str(e)) from None
    except OSError as e:
        raise TargetError(f"cannot read target {os.fspath(path)}: {e.strerror or e}") from None


def _read_csv(path: Path) -> StripTarget:
    raw = _read_file(path, MAX_CSV_BYTES)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise TargetError(f"target {path} is not a text file: expected {STRIP_FORMAT}") from None
    lines = [ln.strip() for ln in text.splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("#")]
    if not lines or [c.strip().lower() for c in lines[0].split(",")] != ["x", "z"]:
        first = lines[0][:40] if lines else "(empty)"
        raise TargetError(f"target {path} is not a strip curve: its first line is {first!r}, expected {STRIP_FORMAT}")
    pts = []
    for n, ln in enumerate(lines[1:], start=2):
        cells = ln.split(",")
        try:
            if len(cells) != 2:
                raise ValueError
            pts.append((float(cells[0]), float(cells[1])))
        except ValueError:
            raise TargetError(f"target {path}: row {n} ({ln[:40]!r}) is not two numbers x,z (mm)") from None
    a = np.array(pts, dtype=np.float64).reshape(-1, 2)
    return check_strip(str(path), a[:, 0], a[:, 1])


def check_strip(source: str, x: Arr, z: Arr) -> StripTarget:
    """A :class:`StripTarget` of points (x, z) mm, or :class:`TargetError`: fewer than 3 points, a value
    that is not finite, x not strictly increasing, or an end farther than :data:`END_TOLERANCE` × span
    from z = 0. x is shifted so that the first point is at 0. ``x`` and ``z`` are (n,) sequences of numbers
    (anything else, a string or None, is a TargetError too)."""
    try:
        x = np.asarray(x, dtype=np.float64)
        z = np.asarray(z, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TargetError(f"target {source}: x and z must be sequences of numbers (mm), got {type(x).__name__} and "
                          f"{type(z).__name__}") from e
    if x.ndim != 1 or z.shape != x.shape:
        raise TargetError(f"target {source}: x and z must be two sequences of the same length, got shapes "
                          f"{x.shape} and {z.shape}")
    if len(x) < 3:
        raise TargetError(f"target {source} has {len(x)} point(s): a strip target needs at least 3 (x, z) points")
    bad = ~(np.isfinite(x) & np.isfinite(z))
    if bad.any():
        k = int(np.argmax(bad))
        raise TargetError(f"target {source}: point {k + 1} (x = {x[k]:g}, z = {z[k]:g}) is not finite: every x and "
                          "z must be a finite number of mm")
    step = np.diff(x)
    if (step <= 0).any():
        k = int(np.argmax(step <= 0))
        raise TargetError(f"target {source}: x must increase strictly along the curve, but point {k + 2} (x = "
                          f"{x[k + 1]:g}) follows x = {x[k]:g}")
    span = float(x[-1] - x[0])
    tol = END_TOLERANCE * span
    for name, v in (("first", z[0]), ("last", z[-1])):
        if abs(v) > tol:
            raise TargetError(f"target {source}: the {name} point is at z = {v:g} mm, but both ends are the pins at "
                              f"z = 0 (within {END_TOLERANCE:.1%} of the span, {tol:.3g} mm)")
    return StripTarget(source, x - x[0], z)


def require_match(target: StripTarget | ClosedTarget, spec_source: str, kind: str) -> None:
    """:class:`TargetError` unless the target fits the spec's tiling: a strip target (CSV mid-line) for a
    honeycomb strip, a closed target (sphere, ellipsoid, mesh) for a closed tiling, ``cap:H`` for a ``hex-cap``
    and ``revolution:…`` for a ``hex-tube`` (:data:`OPEN_TARGETS`; the kind itself is checked by
    :func:`fabpat.design.base.check_kind`)."""
    from fabpat.design.base import CLOSED_KINDS, STRIP_KIND

    takes = dict(OPEN_TARGETS.values())
    if kind in takes and not (isinstance(target, ClosedTarget) and OPEN_TARGETS.get(target.kind, ("",))[0] == kind):
        raise TargetError(f"target {target.source!r} does not fit {spec_source}: a {kind} (an open surface) takes "
                          f"the target {takes[kind]}")
    if kind not in takes and isinstance(target, ClosedTarget) and target.kind in OPEN_TARGETS:
        tiling, syntax = OPEN_TARGETS[target.kind]
        raise TargetError(f"target {target.source!r} ({syntax}) is an open surface for a tiling of kind {tiling!r}, "
                          f"but {spec_source} has tiling.kind = {kind!r}")

    strip = kind == STRIP_KIND
    if strip and isinstance(target, ClosedTarget):
        closed = " or ".join(f'"{k}"' for k in CLOSED_KINDS)
        raise TargetError(f"target {target.source!r} is a closed-tiling target ({target.kind}), but {spec_source} is a "
                          f"honeycomb strip: give {STRIP_FORMAT}, or a closed-tiling spec (tiling.kind = {closed})")
    if not strip and isinstance(target, StripTarget):
        raise TargetError(f"target {target.source} is a strip mid-line, but {spec_source} is a closed tiling "
                          f"(tiling.kind = {kind!r}): give sphere, ellipsoid:A,B,C or a surface mesh file "
                          f"({', '.join(MESH_SUFFIXES)})")


def write_target_csv(path: str | os.PathLike[str], x: Arr, z: Arr) -> None:
    """Write points (mm) as a strip target CSV (header ``x,z``), atomically."""
    from fabpat.io import atomic_outputs

    with atomic_outputs(path) as (tmp,):
        tmp.write_text("x,z\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(x, z, strict=True)), encoding="utf-8")
