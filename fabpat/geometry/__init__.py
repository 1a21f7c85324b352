"""The exact geometry: rational Bézier curves, the outline's segments and loops, vertex stars and
filleting (paper §3.3)."""
