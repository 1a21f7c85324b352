"""Assemblies (paper §5): plates of patterns joined by printed sleeves into strips, spheres and any
polygon-mesh surface.

Every module of the package, by job (heavy libraries are imported inside the functions that need them):

* **What to build** — ``spec`` (TOML specs, every value checked), ``spec_types`` (its tables as plain
  data), ``spec_patterns`` (its ``[patterns]`` table), ``spec_tiling`` (its ``[tiling]`` table) and
  ``spec_tables`` (reading its file and tables);
  ``tiling`` (skeleton surfaces); ``mesh_tiling`` (a polygon-mesh file read and checked as a tiling) and
  ``ply`` (its PLY reader); ``polyhedra`` (Goldberg polyhedra, hexagon tubes and caps); ``choice`` (one
  pattern per face, by the spec's ``[patterns]``); ``members`` (family members as candidates); ``rules``
  (stiffness-based pattern choice);
  ``provenance`` (where each chosen pattern and its catalog energies come from).
* **Where the parts go** — ``placement`` (plates and sleeves in 3D); ``sleeve`` (the connector B-rep);
  ``parts`` (distinct solids and meshes, built once); ``checks`` (counts, midpoints, interference);
  ``nesting`` and ``sheets`` (laser sheets); ``net`` (unfolding).
* **Solving the assembly** — ``model`` (placed plate meshes joined by sleeves, one shell model);
  ``simulate`` (the strip pushed into its arch); ``closure`` (the sphere closed by its sleeves);
  ``simulation`` (``simulate_assembly``, the front door for every kind); ``result`` (what it returns,
  ``AssemblySimulation``, and the one record of its fields that the CLI and a kit's prediction print);
  ``sizing`` (the mesh and memory an assembly's solve would take, checked before meshing); ``predict`` (the kit's
  prediction) and ``preview`` (the predicted bent shape as GLB, PNG and mesh).
* **The kit** — ``build`` (``assemble``: a spec in, a folder out) and ``kit_result`` (what it returns, the
  plates' fabrication checks); ``kit_files`` (every output written);
  ``kit_folder`` (what may be replaced, and the swap); ``export`` (STEP/STL/GLB); ``render`` (PNG);
  ``bom`` (bill of materials and joint table).
* **One-piece panels** — ``panel`` (a panel's plates fused into one exact outline and solid, and its
  end-shortening model); ``panel_mesh`` (a panel from a flat mesh file: its checks, its exact tiling, its
  ends); ``panel_sheet`` (its hull on the sheet); ``panel_kit`` (its kit: the part in every
  format, nested); ``panel_bom`` (its BOM).
"""
