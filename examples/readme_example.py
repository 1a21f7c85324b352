import fabpat

fp = fabpat.pattern("0x0488").fillet(weight=0.2)              # exact outline: lines + rational arcs
print(len(fabpat.library()), fp.id, f"{fp.metrics.area:.2f}")  # 430 patterns; area in mm²
fp.export("0x0488.step")                                      # or .stl .3mf .dxf .svg .3dm
r = fabpat.simulate(fp, "cantilever")                         # nonlinear shell, 1.5 N tip load; mesh-converged
print(f"{r.energy:.4f} {r.max_displacement:.2f}")             # strain energy N·mm, max |u| mm
r.to_png("0x0488-cantilever.png")
stiff = min(fabpat.catalog(), key=lambda row: row["energy_dome"])
print(stiff["id"], f"{stiff['energy_dome']:.2f}")             # the stiffest dome-former
