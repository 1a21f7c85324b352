"""Assemblies (paper §5): plates of patterns joined by printed sleeves into strips and spheres.

One module per concern: ``spec`` (TOML specs), ``tiling`` (skeleton surfaces), ``rules`` (stiffness-based
pattern choice), ``placement`` (plates and sleeves in 3D), ``sleeve`` (the connector B-rep), ``parts``
(distinct solids and meshes), ``checks`` (counts, midpoints, interference), ``nesting`` and ``sheets``
(laser sheets), ``net`` (unfolding), ``export`` (STEP/STL/GLB), ``render`` (PNG), ``bom`` and ``build``
(the ``fabpat assemble`` pipeline). Heavy libraries are imported inside the functions that need them.
"""
