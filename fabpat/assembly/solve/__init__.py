"""Solving an assembly as one shell model (paper §5, §6): the plates' meshes joined by their sleeves.

``model`` (the model every kind shares: placed plate meshes, the sleeves' rigid links, the per-plate
bookkeeping, the material), ``strip`` (a strip pushed into its arch by end shortening), ``closure`` (a closed
tiling closed by its sleeves), ``panel`` (a fused panel as one plate), ``sizing`` (the mesh and memory a solve
would take, checked before meshing), ``simulation`` (:func:`simulate_assembly`, the front door for every kind),
``result`` (:class:`AssemblySimulation`), ``predict`` (a kit's prediction), ``preview`` (the predicted shape as
GLB, PNG and mesh).
"""
