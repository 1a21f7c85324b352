"""Assemblies (paper §5): plates of patterns joined by printed sleeves into strips, spheres and any
polygon-mesh surface.

The front door is five names; the rooms behind it, in the order they import one another (a room imports only
rooms before it):

* ``surface`` — the surfaces tiled: tilings, polyhedra, mesh files, the joints' dimensions;
* ``spec`` — what to build: a TOML spec read and checked;
* ``place`` — where the parts go: placement, sleeves, necks, parts, checks, nesting, fused panels;
* ``choose`` — which pattern on which face: rules, family members, provenance;
* ``show`` — pictures and 3-D files of a placement;
* ``solve`` — one shell model for every kind (strip, closure, panel), its result and the kit's prediction;
* ``kit`` — ``assemble``: the files, folder, BOM, sheets and net.

Example::

    from fabpat.assembly import assemble, load_spec, simulate_assembly
    spec = load_spec("assemblies/truncated-icosahedron.toml")
    sim = simulate_assembly(spec, h=6.0)          # the sphere closed by its sleeves
    kit = assemble(spec, "sphere-kit")            # the checked kit, written

Heavy libraries (OCP, trimesh, Triangle, numba) are imported inside the functions that need them, so
importing this package is cheap.
"""

from fabpat.assembly.kit.build import assemble
from fabpat.assembly.solve.result import AssemblySimulation
from fabpat.assembly.solve.simulation import simulate_assembly
from fabpat.assembly.spec import AssemblySpec, load_spec

__all__ = ["AssemblySimulation", "AssemblySpec", "assemble", "load_spec", "simulate_assembly"]
