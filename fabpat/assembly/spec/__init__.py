"""What to build: an assembly's TOML spec read and every value checked (paper §5).

``load`` (:func:`load_spec`, :func:`parse_spec`: the tables in order, the sheet checked against the parts),
``types`` (the tables as plain frozen data: :class:`AssemblySpec` and its parts), ``tables`` (reading the file
and a table's keys, one line per problem), ``tiling`` (the ``[tiling]`` table), ``patterns`` (the
``[patterns]`` table), ``sheet`` (whether a panel fits its sheet, and the nesting grid's step both share).

Example::

    from fabpat.assembly.spec import load_spec
    spec = load_spec("assemblies/truncated-icosahedron.toml")
    spec.tiling.kind, spec.plates.thickness   # ('truncated-icosahedron', 1.0)
"""

from fabpat.assembly.spec.load import (
    check_sheet_fits,
    load_spec,
    parse_spec,
    printed_angle,
    sleeve_angle,
    smallest_dihedral,
)
from fabpat.assembly.spec.tables import SpecProblems
from fabpat.assembly.spec.types import AssemblySpec

__all__ = ["AssemblySpec", "SpecProblems", "check_sheet_fits", "load_spec", "parse_spec", "printed_angle",
           "sleeve_angle", "smallest_dihedral"]
