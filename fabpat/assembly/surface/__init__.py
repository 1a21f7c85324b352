"""The surfaces an assembly tiles (paper §5): skeleton tilings of regular polygons and the joints on them.

``tiling`` (a skeleton surface: vertices, polygon faces, edges, dihedral angles; the truncated icosahedron
and the honeycomb strip), ``polyhedra`` (Goldberg polyhedra, hexagon tubes and caps), ``mesh_tiling`` (a
polygon-mesh file read and checked as a tiling), ``ply`` (its PLY reader), ``panel_mesh`` (a flat mesh laid on
its exact tiling of regular polygons, and a panel's ends), ``joints`` (the sleeve's dimensions on a tiling's
edge: setbacks, the skeleton's edge, the joint's directions). Nothing here knows a spec or a pattern.
"""
