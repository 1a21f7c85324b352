"""``fabpat assemble SPEC --out DIR``: the complete kit of an assembly spec (see fabpat.assembly.build).

The command only parses its options, shows a progress bar on stderr and prints the files written
(one per line, on stdout, relative to the current folder). Errors are one line on stderr, exit 2.
"""

from __future__ import annotations

import os
from pathlib import Path

import click


@click.command("assemble")
@click.argument("spec", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="Output folder (created; an earlier `fabpat assemble` output there is replaced).")
@click.option("--progress/--no-progress", default=True, show_default=True, help="Progress bar on stderr.")
@click.option("--timestamp", default=None, metavar="ISO8601",
              help="Fixed STEP header time, for byte-reproducible files.")
def assemble_cmd(spec: str, out: str, progress: bool, timestamp: str | None) -> None:
    """Build, check and write everything to fabricate and assemble the SPEC (a TOML file).

    Writes a STEP assembly, one STL per distinct part, a GLB preview, laser sheets (DXF), the net
    (SVG), a bill of materials (CSV, Markdown), an assembly picture (PNG) and manifest.json.

    Example: fabpat assemble assemblies/truncated-icosahedron.toml --out sphere-kit
    """
    from fabpat.assembly.build import assemble, steps
    from fabpat.assembly.spec import load_spec

    parsed = load_spec(spec)
    names = steps(parsed)
    bar = None
    if progress:
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        bar = Progress(TextColumn("{task.description:<10}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                       TimeElapsedColumn(), console=Console(stderr=True), transient=True)
        bar.start()
        task = bar.add_task("assemble", total=len(names))
    done = 0

    def tell(step: str) -> None:
        nonlocal done
        if bar is not None:
            bar.update(task, description=step, completed=done)
        done += 1

    try:
        result = assemble(parsed, out, tell, timestamp)
    finally:
        if bar is not None:
            bar.stop()
    for line in result.report.lines():
        click.echo(f"check: {line}", err=True)
    for name in result.files:
        click.echo(os.path.join(out, name) if not Path(out).is_absolute() else str(Path(out) / name))


COMMANDS = [assemble_cmd]
