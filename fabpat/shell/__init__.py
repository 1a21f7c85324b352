"""Flat 3-node shell triangles (OPT membrane + DKMT bending/shear), linear and corotational solves."""

from fabpat.shell.element import Material
from fabpat.shell.results import ShellResult
from fabpat.shell.solve import ShellProblem, solve_linear, solve_nonlinear

__all__ = ["Material", "ShellProblem", "ShellResult", "solve_linear", "solve_nonlinear"]
