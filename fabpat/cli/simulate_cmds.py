"""``fabpat simulate``: fillet, mesh and load one pattern in the paper's scenarios (§4.1)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import TYPE_CHECKING

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
from fabpat.errors import FabpatError
from fabpat.io import atomic_outputs, check_distinct, check_suffix
from fabpat.patterns.variation import Variation
from fabpat.simulation.mesh import DEFAULT_MAX_ELEMENTS

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.simulation.energies import ScenarioEnergies, ScenarioRun

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

    The work is :func:`fabpat.simulation.energies.scenario_energies`'s (as ``fabpat sweep``).
    """
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.progress import Progress
    from fabpat.simulation.energies import scenario_energies
    from fabpat.simulation.scenarios import SCENARIOS

    scenarios = SCENARIOS if scenario == "all" else (scenario,)
    many = len(scenarios) > 1
    outputs = _outputs(vtu, png, inp, scenarios)
    pattern = get_pattern(pattern_id, sides, depth, edge)
    filleted = fillet_pattern(pattern, weight, variation)  # its outline carries its polygon
    warn_inert_variation(variation, filleted.variation, pattern.id)
    given = variation_given()
    member = "".join(f" {k}={v:g}" for k, v in variation.items().items() if k in given or v != 1.0)
    # a heartbeat line while each scenario's solves block (the solver has no progress callback)
    with atomic_outputs(*outputs.values()) as temps, Progress("simulate", total=len(scenarios),
                                                              enabled=progress) as bar:
        got = scenario_energies(filleted, scenarios, h=h, extrapolate=extrapolate, thickness=thickness, E=E, nu=nu,
                                nonlinear=not linear, max_elements=max_elements, name=f"{pattern.id}{member}",
                                progress=bar)
        rows = [{"id": pattern.id, "sides": sides, **variation.items(), **_summary(run)} for run in got.runs]
        _write_files(got, dict(zip(outputs, temps, strict=True)), thickness=thickness, E=E, nu=nu, linear=linear,
                     inp_element=inp_element)
    if as_json:
        click.echo(json.dumps(rows if many else rows[0], indent=1))
    else:
        for row in rows:
            click.echo(_text_line(row) + member)
    for path in outputs.values():
        click.echo(f"wrote {path}", err=True)  # stdout is data (key=value lines or JSON)


def _outputs(vtu: str | None, png: str | None, inp: str | None,
             scenarios: tuple[str, ...]) -> dict[tuple[str, str], str]:
    """{(kind, scenario): file name} of the result files asked for, checked before any work: distinct
    names (--vtu x --png x would overwrite one with the other) with the right suffixes."""
    from fabpat.simulation.scenarios import PNG_SUFFIXES, VTU_SUFFIXES

    many = len(scenarios) > 1
    outputs = {(kind, sc): str(_per_scenario(path, sc, many))
               for kind, path in (("vtu", vtu), ("png", png), ("inp", inp)) for sc in scenarios if path is not None}
    check_distinct(outputs.values())
    for option, path, valid in (("--vtu", vtu, VTU_SUFFIXES), ("--png", png, PNG_SUFFIXES),
                                ("--export-inp", inp, (".inp",))):
        if path is not None:
            check_suffix(path, valid, option)
    return outputs


def _summary(run: ScenarioRun) -> dict[str, object]:
    """A scenario's JSON fields (:meth:`fabpat.simulation.convergence.ConvergedResult.summary`)."""
    if run.result is None or not run.converged:  # scenario_energies raises on nonconvergence; this guards it
        raise FabpatError(f"{run.scenario}: the solver did not converge")
    return run.result.summary()


def _text_line(row: dict) -> str:
    """One scenario as plain key=value fields: the JSON field names, units in --help; a line splits on
    spaces, then on "="."""
    return (f"id={row['id']} scenario={row['scenario']} energy={row['energy']:.6g} "
            f"max_displacement={row['max_displacement']:.4g} converged={str(bool(row['converged'])).lower()} "
            f"iterations={row['iterations']} seconds={row['seconds']:.2f} nodes={row['nodes']} "
            f"elements={row['elements']} h={','.join(f'{x:g}' for x in row['h'])}")


def _write_files(got: ScenarioEnergies, tmp_of: dict[tuple[str, str], Path], *, thickness: float, E: float,
                 nu: float, linear: bool, inp_element: str) -> None:
    """The asked result files of each scenario, into their temporary names: fields and mesh of the finest
    mesh, the picture captioned with the API's (extrapolated) energy."""
    from fabpat.simulation.inp import write_inp
    from fabpat.simulation.png_result import write_png
    from fabpat.simulation.vtu import write_vtu

    mesh, filleted = got.mesh, got.filleted
    assert mesh is not None and filleted is not None  # scenario_energies raised otherwise
    for run in got.runs:
        sc, c = run.scenario, run.result
        assert c is not None
        if ("vtu", sc) in tmp_of:
            write_vtu(tmp_of["vtu", sc], mesh.V, mesh.F, c.fine.result)
        if ("png", sc) in tmp_of:
            caption = dataclasses.replace(c.as_result(), pattern_id=filleted.pattern.id,
                                          member=filleted.variation.tag()).caption()
            write_png(tmp_of["png", sc], mesh.V, mesh.F, c.fine.result, title=caption)
        if ("inp", sc) in tmp_of:
            write_inp(tmp_of["inp", sc], mesh, sc, sides=filleted.sides, thickness=thickness, E=E, nu=nu,
                      nonlinear=not linear, element=inp_element.upper(), pattern=filleted.label)


COMMANDS = [simulate_cmd]
