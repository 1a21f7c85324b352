"""fabpat: fabricable geometric patterns for flat mechanical metamaterials.

The Python front door (everything is imported on first use, so ``import fabpat`` stays instant)::

    import fabpat

    lib = fabpat.library(sides=6, depth=2, edge=36.0)   # 430 patterns: iterate, lib["0x0488"], len(lib)
    p = fabpat.pattern("0x0488")                          # depth from the ID's length
    fp = p.fillet(weight=0.2)                             # exact outline; knows sides, edge, weight
    fabpat.variations()                                   # each pattern's family: p.fillet(bridge_weight=0.5)
    fp.export("p.step")                                   # .step .stl .3mf .dxf .svg, by suffix
    r = fabpat.simulate(fp, "dome")                       # r.energy (N·mm, mesh-converged), r.to_vtu(…)
    rows = fabpat.catalog()                               # the built-in catalog; rows.to_dataframe()
    fabpat.predict(["0x0488"]).records()                  # energies, min width, area ± 90 % in microseconds
    sim = fabpat.simulate_assembly("assemblies/truncated-icosahedron.toml")  # the sphere, closed
    sim.fields()["sphericity_rms"]                        # and every simulate-assembly field
    kit = fabpat.assemble("assemblies/truncated-icosahedron.toml", "sphere-kit")  # the checked kit, written
    d = fabpat.design("arch.csv", "assemblies/graded-strip.toml")  # one pattern per column for a target arch

``fabpat.library``, ``fabpat.pattern``, ``fabpat.catalog`` and ``fabpat.design`` are also modules
(``fabpat.patterns.library``, ``fabpat.patterns.pattern``, ``fabpat.catalog``, ``fabpat.design``): calling one
calls :func:`fabpat.patterns.library.library`, :func:`fabpat.patterns.library.pattern`,
:func:`fabpat.catalog.catalog` or :func:`fabpat.design.api.design`. A function could not keep such a name: the
import system sets the package attribute to the submodule whenever the submodule is first imported
(``from fabpat.design import design`` before ``fabpat.design(...)``), so the module itself is the call
(:mod:`fabpat._callable`), whichever is imported first. The modules live in one package
per stage of the pipeline (``patterns``, ``geometry``, ``exchange``, ``simulation``, ``shell``, ``catalog``,
``views``, ``assembly``, ``design``, ``cli``); their earlier flat names (``fabpat.fillet``) still import
(:mod:`fabpat._moved`).
"""

import importlib as _importlib

from fabpat import _moved  # noqa: F401 - the earlier flat module names keep importing

__version__ = "0.1.0"

# name → "module" (the module itself, callable) or "module:attribute"; resolved on first access
_LAZY = {
    "library": "fabpat.patterns.library",
    "pattern": "fabpat.patterns.pattern",
    "catalog": "fabpat.catalog",
    "simulate": "fabpat.simulation.convergence:simulate",
    "simulate_assembly": "fabpat.assembly.solve.simulation:simulate_assembly",
    "assemble": "fabpat.assembly.kit.build:assemble",
    "design": "fabpat.design",
    "predict": "fabpat.catalog.response_file:predict",
    "variations": "fabpat.patterns.variation:variations",
    "Variation": "fabpat.patterns.variation:Variation",
    "Library": "fabpat.patterns.library:Library",
    "Pattern": "fabpat.patterns.pattern:Pattern",
    "FilletedPattern": "fabpat.geometry.fillet:FilletedPattern",
    "Outline": "fabpat.geometry.outline:Outline",
    "Part": "fabpat.exchange.registry:Part",
    "RegionMetrics": "fabpat.patterns.metrics:RegionMetrics",
    "ScenarioResult": "fabpat.simulation.scenarios:ScenarioResult",
    "SCENARIOS": "fabpat.simulation.scenarios:SCENARIOS",
    "FabpatError": "fabpat.errors:FabpatError",
    "PatternError": "fabpat.errors:PatternError",
    "GeometryError": "fabpat.errors:GeometryError",
    "ExportError": "fabpat.errors:ExportError",
    "SolverError": "fabpat.errors:SolverError",
    "SpecError": "fabpat.errors:SpecError",
    "CatalogError": "fabpat.catalog:CatalogError",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str) -> object:  # PEP 562: import on first use
    target = _LAZY.get(name)
    if target is None:
        raise AttributeError(f"module 'fabpat' has no attribute {name!r}")
    module, _, attr = target.partition(":")
    value: object = _importlib.import_module(module)
    if attr:
        value = getattr(value, attr)
        globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
