"""Where the parts go (paper §5): plates and sleeves placed on the skeleton, and what must hold for them.

``placement`` (plate types, frames, the sleeves at every joint), ``sleeve`` (the printed connector's exact
solid), ``necks`` (whether a pattern's neck fits the sleeve's slot), ``parts`` (the distinct solids and meshes,
built once), ``checks`` (counts, midpoints, interference), ``nesting`` (polygons packed on a sheet),
``panel`` (a one-piece panel: its plates fused into one exact outline).
"""
