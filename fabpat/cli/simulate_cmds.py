"""``fabpat simulate``: fillet, mesh and load one pattern in the paper's scenarios (§4.1)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import click

from fabpat.cli.options import (
    edge_option,
    id_depth_option,
    max_elements_option,
    modulus_option,
    number_option,
    poisson_option,
    sides_option,
    thickness_option,
    variation_given,
    variation_option,
    warn_inert_variation,
    weight_option,
)
from fabpat.errors import FabpatError, SolverError
from fabpat.io import atomic_outputs, check_distinct, check_suffix
from fabpat.patterns.variation import Variation
from fabpat.simulation.mesh import DEFAULT_MAX_ELEMENTS

SCENARIO_CHOICES = ("cantilever", "cylinder", "dome", "all")


def _per_scenario(path: str | None, scenario: str, many: bool) -> str | None:
    """``out.vtu`` → ``out-dome.vtu`` when several scenarios are written to one name."""
    if path is None or not many:
        return path
    p = Path(path)
    return str(p.with_name(f"{p.stem}-{scenario}{p.suffix}"))


@click.command("simulate")
@click.argument("pattern_id", metavar="ID")
@sides_option
@id_depth_option
@edge_option
@weight_option
@variation_option
@click.option("--scenario", type=click.Choice(SCENARIO_CHOICES, case_sensitive=False), default="all", show_default=True,
              help="Load case of the paper (all = the three in turn).")
@click.option("--linear", is_flag=True, help="Linear analysis instead of geometrically nonlinear.")
@number_option("--h", "h", range_name="h", default=None,
               help="Target mesh edge length in mm (at most twice the pattern's min_width): one mesh of this "
                    "size unless --extrapolate is also given [default: 2.5, or 1.1 × min_width for narrower "
                    "necks, refined to half, extrapolated; with --no-extrapolate 1.5].")
@click.option("--extrapolate/--no-extrapolate", default=None,
              help="Mesh at h, refine that mesh once (h/2, nested) and report the energy extrapolated to the "
                   "mesh-converged value (Richardson, order 1.2; other fields from the finer mesh) [default: "
                   "on, as the built-in catalog, unless --h is given: then one mesh of that size].")
@thickness_option
@modulus_option
@poisson_option
@max_elements_option(DEFAULT_MAX_ELEMENTS, "mesh elements")
@click.option("--vtu", type=click.Path(dir_okay=False), help="Deformed mesh with fields for ParaView (.vtu).")
@click.option("--png", type=click.Path(dir_okay=False), help="Picture of the deformed pattern coloured by energy.")
@click.option("--export-inp", "inp", type=click.Path(dir_okay=False),
              help="Abaqus/CalculiX input deck of the same mesh, loads and supports.")
@click.option("--inp-element", type=click.Choice(["S6", "S3", "STRI3"], case_sensitive=False), default="S6",
              show_default=True, help="Element of --export-inp: S6 (CalculiX), or S3/STRI3 for Abaqus.")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON.")
@click.option("--progress/--no-progress", default=True, show_default=True,
              help="Progress on stderr: a bar on a terminal, else a line every few seconds "
                   "(FABPAT_PROGRESS_INTERVAL seconds, default 5) and one per scenario finished.")
def simulate_cmd(
    pattern_id: str, sides: int, depth: int | None, edge: float, weight: float, variation: Variation, scenario: str,
    linear: bool, h: float | None, extrapolate: bool | None,
    thickness: float, E: float, nu: float, vtu: str | None, png: str | None, inp: str | None, inp_element: str,
    as_json: bool, max_elements: int, progress: bool,
) -> None:
    """Simulate one pattern in the Cantilever, Cylinder and/or Dome scenario.

    Prints one line per scenario of plain key=value fields (the --json field names): id, scenario,
    energy (total strain energy, N·mm), max_displacement (mm), converged, iterations, seconds (s),
    nodes, elements, h (the mesh sizes in mm, comma-separated: two when the energy is extrapolated).
    By default the energy is the mesh-converged value, as in the built-in catalog: extrapolated from a
    mesh of 2.5 mm (1.1 × min_width for necks under 2.27 mm) and its nested refinement, half that
    (Richardson; JSON ``h`` and ``mesh_energies`` list both; the other fields and the files are the
    finer mesh's, seconds the sum of both). With --h the
    pattern is solved on one mesh of that size (add --extrapolate for h and its refinement h/2);
    --no-extrapolate solves one mesh of 1.5 mm.
    With --scenario all, file options get the scenario appended (out.vtu → out-dome.vtu).
    --variation NAME=VALUE simulates that member of the pattern's family (`fabpat variations`); the
    JSON rows carry every variation parameter, the text lines the ones given.

    Example: fabpat simulate 0x2d88 --scenario dome --vtu dome.vtu --png dome.png --json

    Long because most of it is the command's options checked and passed on, and its outputs written; the work
    is the library's.
    """
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.progress import Progress
    from fabpat.simulation.convergence import ONE_MESH_H, mesh_converged, run_converged
    from fabpat.simulation.inp import write_inp
    from fabpat.simulation.png_result import write_png
    from fabpat.simulation.scenarios import PNG_SUFFIXES, SCENARIOS, VTU_SUFFIXES, mesh_filleted
    from fabpat.simulation.vtu import write_vtu

    if extrapolate is None:  # converged by default; a mesh size given means that mesh
        extrapolate = h is None
    if h is None and not extrapolate:
        h = ONE_MESH_H
    scenarios = SCENARIOS if scenario == "all" else (scenario,)
    many = len(scenarios) > 1
    outputs = {
        (kind, sc): _per_scenario(path, sc, many)
        for kind, path in (("vtu", vtu), ("png", png), ("inp", inp))
        for sc in scenarios
        if path is not None
    }
    check_distinct(outputs.values())  # before the work: --vtu x --png x would overwrite one with the other
    for option, path, valid in (("--vtu", vtu, VTU_SUFFIXES), ("--png", png, PNG_SUFFIXES),
                                ("--export-inp", inp, (".inp",))):
        if path is not None:
            check_suffix(path, valid, option)
    pattern = get_pattern(pattern_id, sides, depth, edge)
    filleted = fillet_pattern(pattern, weight, variation)  # its outline carries its polygon
    warn_inert_variation(variation, filleted.variation, pattern.id)
    given = variation_given()
    member = "".join(f" {k}={v:g}" for k, v in variation.items().items() if k in given or v != 1.0)
    rows = []
    # a heartbeat line while each scenario's solves block (the solver has no progress callback)
    with atomic_outputs(*outputs.values()) as temps, Progress("simulate", total=len(scenarios),
                                                              enabled=progress) as bar:
        bar.update("meshing", 0)
        # by default the converged run's coarse h (2.5 mm; 1.1 × min_width for necks under 2.27 mm)
        meshes = mesh_converged(filleted, h, max_elements=max_elements) if extrapolate else \
            [(float(h), mesh_filleted(filleted, float(h), max_elements=max_elements))]  # type: ignore[arg-type]
        mesh = meshes[-1][1]  # fields, files and node counts come from the finest mesh
        sizes = " and ".join(f"{m.n_elements} elements" for _, m in meshes)
        tmp_of = dict(zip(outputs, temps, strict=True))
        for k, sc in enumerate(scenarios):
            bar.update(f"{sc} ({k + 1} of {len(scenarios)}) on {sizes}", k)
            try:
                c = run_converged(meshes, sc, sides=sides, edge=edge, thickness=thickness, E=E, nu=nu,
                                  nonlinear=not linear)
            except SolverError as e:  # say which of the scenarios and which family member
                raise SolverError(f"{sc} scenario of {pattern.id}{member}: {e}") from None
            row = c.summary()
            bar.item(f"{sc} finished ({k + 1} of {len(scenarios)}), energy {row['energy']:.6g} N·mm")
            if not row["converged"]:  # run_scenario raises on nonconvergence; this guards the contract
                raise FabpatError(f"{sc}: the solver did not converge")
            rows.append({"id": pattern.id, "sides": sides, **variation.items(), **row})
            if ("vtu", sc) in tmp_of:
                write_vtu(tmp_of["vtu", sc], mesh.V, mesh.F, c.fine.result)
            if ("png", sc) in tmp_of:
                caption = dataclasses.replace(c.as_result(), pattern_id=pattern.id,
                                              member=filleted.variation.tag()).caption()  # the API's energy
                write_png(tmp_of["png", sc], mesh.V, mesh.F, c.fine.result, title=caption)
            if ("inp", sc) in tmp_of:
                write_inp(tmp_of["inp", sc], mesh, sc, sides=sides, thickness=thickness, E=E, nu=nu,
                          nonlinear=not linear, element=inp_element.upper(), pattern=filleted.label)
    if as_json:
        click.echo(json.dumps(rows if many else rows[0], indent=1))
    else:
        for row in rows:
            # the JSON field names, units in --help: a line splits on spaces, then on "="
            click.echo(
                f"id={row['id']} scenario={row['scenario']} energy={row['energy']:.6g} "
                f"max_displacement={row['max_displacement']:.4g} converged={str(bool(row['converged'])).lower()} "
                f"iterations={row['iterations']} seconds={row['seconds']:.2f} nodes={row['nodes']} "
                f"elements={row['elements']} h={','.join(f'{x:g}' for x in row['h'])}"
                + member
            )
    for path in outputs.values():
        click.echo(f"wrote {path}", err=True)  # stdout is data (key=value lines or JSON)


COMMANDS = [simulate_cmd]
