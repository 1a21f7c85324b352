"""Simulating one pattern: mesh sizes and meshing, the paper's scenarios (§4.1), mesh-converged
energies, and the files of a solved shell (VTU, PNG, CalculiX deck)."""
