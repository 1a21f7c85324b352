"""The import paths of modules from before the stage packages (``fabpat.fillet`` is now
``fabpat.geometry.fillet``): a finder on ``sys.meta_path`` answers an import of an old name with the
module under its new one, so code written against the flat layout keeps working and both names are one
module object (the Python reference, "The meta path": a finder may return any module). It computes
nothing, so the catalog's solver digest leaves it out (:mod:`fabpat.catalog.version`).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import types
from collections.abc import Sequence

#: old module name → its module now
MOVED = {
    "fabpat.lattice": "fabpat.patterns.lattice",
    "fabpat.metrics": "fabpat.patterns.metrics",
    "fabpat.pattern": "fabpat.patterns.pattern",
    "fabpat.library": "fabpat.patterns.library",
    "fabpat.variation": "fabpat.patterns.variation",
    "fabpat.curves": "fabpat.geometry.curves",
    "fabpat.conics": "fabpat.geometry.conics",
    "fabpat.polyline": "fabpat.geometry.polyline",
    "fabpat.segments": "fabpat.geometry.segments",
    "fabpat.outline": "fabpat.geometry.outline",
    "fabpat.stars": "fabpat.geometry.stars",
    "fabpat.fillet": "fabpat.geometry.fillet",
    "fabpat.cad": "fabpat.exchange.cad",
    "fabpat.contours": "fabpat.exchange.contours",
    "fabpat.mesh_size": "fabpat.simulation.mesh_size",
    "fabpat.mesh": "fabpat.simulation.mesh",
    "fabpat.scenarios": "fabpat.simulation.scenarios",
    "fabpat.convergence": "fabpat.simulation.convergence",
    "fabpat.sweep": "fabpat.catalog.sweep",
    "fabpat.restamp": "fabpat.catalog.restamp",
    "fabpat.family": "fabpat.catalog.family",
    "fabpat.pictures": "fabpat.views.pictures",
    "fabpat.plots": "fabpat.views.plots",
    "fabpat.browse": "fabpat.views.browse",
    "fabpat.exchange.vtu": "fabpat.simulation.vtu",
    "fabpat.exchange.png_result": "fabpat.simulation.png_result",
    "fabpat.exchange.inp": "fabpat.simulation.inp",
    "fabpat.assembly.tiling": "fabpat.assembly.surface.tiling",
    "fabpat.assembly.polyhedra": "fabpat.assembly.surface.polyhedra",
    "fabpat.assembly.mesh_tiling": "fabpat.assembly.surface.mesh_tiling",
    "fabpat.assembly.ply": "fabpat.assembly.surface.ply",
    "fabpat.assembly.panel_mesh": "fabpat.assembly.surface.panel_mesh",
    "fabpat.assembly.spec_types": "fabpat.assembly.spec.types",
    "fabpat.assembly.spec_patterns": "fabpat.assembly.spec.patterns",
    "fabpat.assembly.spec_tables": "fabpat.assembly.spec.tables",
    "fabpat.assembly.spec_tiling": "fabpat.assembly.spec.tiling",
    "fabpat.assembly.panel_sheet": "fabpat.assembly.spec.sheet",
    "fabpat.assembly.placement": "fabpat.assembly.place.placement",
    "fabpat.assembly.sleeve": "fabpat.assembly.place.sleeve",
    "fabpat.assembly.necks": "fabpat.assembly.place.necks",
    "fabpat.assembly.parts": "fabpat.assembly.place.parts",
    "fabpat.assembly.nesting": "fabpat.assembly.place.nesting",
    "fabpat.assembly.checks": "fabpat.assembly.place.checks",
    "fabpat.assembly.panel": "fabpat.assembly.place.panel",
    "fabpat.assembly.choice": "fabpat.assembly.choose.choice",
    "fabpat.assembly.members": "fabpat.assembly.choose.members",
    "fabpat.assembly.rules": "fabpat.assembly.choose.rules",
    "fabpat.assembly.provenance": "fabpat.assembly.choose.provenance",
    "fabpat.assembly.render": "fabpat.assembly.show.render",
    "fabpat.assembly.export": "fabpat.assembly.show.export",
    "fabpat.assembly.model": "fabpat.assembly.solve.model",
    "fabpat.assembly.simulate": "fabpat.assembly.solve.strip",
    "fabpat.assembly.closure": "fabpat.assembly.solve.closure",
    "fabpat.assembly.result": "fabpat.assembly.solve.result",
    "fabpat.assembly.predict": "fabpat.assembly.solve.predict",
    "fabpat.assembly.sizing": "fabpat.assembly.solve.sizing",
    "fabpat.assembly.simulation": "fabpat.assembly.solve.simulation",
    "fabpat.assembly.preview": "fabpat.assembly.solve.preview",
    "fabpat.assembly.build": "fabpat.assembly.kit.build",
    "fabpat.assembly.kit_files": "fabpat.assembly.kit.files",
    "fabpat.assembly.kit_folder": "fabpat.assembly.kit.folder",
    "fabpat.assembly.kit_result": "fabpat.assembly.kit.result",
    "fabpat.assembly.bom": "fabpat.assembly.kit.bom",
    "fabpat.assembly.sheets": "fabpat.assembly.kit.sheets",
    "fabpat.assembly.net": "fabpat.assembly.kit.net",
    "fabpat.assembly.panel_kit": "fabpat.assembly.kit.panel",
    "fabpat.assembly.panel_bom": "fabpat.assembly.kit.panel_bom",
}


class _OldName(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old name of :data:`MOVED` and loads it as the module it moved to."""

    def __init__(self) -> None:
        self._specs: dict[str, importlib.machinery.ModuleSpec | None] = {}

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: types.ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        """A spec for an old name, else None (the other finders go on)."""
        return importlib.util.spec_from_loader(fullname, self) if fullname in MOVED else None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        """The module under its new name (imported if it is not yet)."""
        module = importlib.import_module(MOVED[spec.name])
        self._specs[module.__name__] = module.__spec__
        return module

    def exec_module(self, module: types.ModuleType) -> None:
        """Nothing runs (the module ran under its new name); the import system has just given the module
        the old name's spec, so its own is put back (``__spec__.name`` stays the new name)."""
        module.__spec__ = self._specs.pop(module.__name__, module.__spec__)


if not any(isinstance(f, _OldName) for f in sys.meta_path):
    sys.meta_path.insert(0, _OldName())  # before the path finders: an old file left on disk is not run
