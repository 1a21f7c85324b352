"""The design's files: ``design.toml`` (a complete spec with every tile's pattern), ``design.json`` (the
record), ``design.png`` (target and predicted mid-lines, each column's pattern) and, with ``kit``, the
``fabpat assemble`` kit of design.toml in ``kit/``.

Everything is written into a temporary folder next to the output folder and renamed to it at the end
(as ``fabpat assemble`` does): on any error nothing is left, and an earlier design output there is
replaced only on success; any other non-empty folder is refused before any work.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from fabpat.errors import ExportError

GENERATOR = "fabpat design"
FILES = ("design.toml", "design.json", "design.png")
#: the files a design may write beside them: a mapped tiling's mesh (fabpat.design.mapped.MESH_NAME)
EXTRA_FILES = ("mapped.obj",)


def design_in_the_way(p: Path) -> str | None:
    """Why folder ``p`` may not be replaced by a design output (one phrase), or None: it is missing, empty,
    or holds only an earlier `fabpat design` output (its design.json says so, no other file beside
    :data:`FILES`, and a ``kit/`` that :func:`fabpat.assembly.kit.folder.foreign_entries` accepts). A
    user's file in the folder is never deleted."""
    from fabpat.assembly.kit.folder import foreign_entries

    if not p.exists() and not p.is_symlink():
        return None
    if p.is_symlink() or not p.is_dir():
        return "it is not a folder"
    names = sorted(e.name for e in p.iterdir())
    if not names:
        return None
    earlier = False
    with contextlib.suppress(OSError, ValueError, AttributeError, RecursionError):
        earlier = json.loads((p / "design.json").read_text(encoding="utf-8")).get("generator") == GENERATOR
    if not earlier:
        return "it is not an earlier `fabpat design` output"
    for name in names:
        entry = p / name
        if name == "kit" and entry.is_dir() and not entry.is_symlink():
            why = foreign_entries(entry)
            if why is not None:
                return f"its kit/ {why}"
        elif name not in FILES + EXTRA_FILES or entry.is_symlink() or not entry.is_file():
            return f"it holds {name}, which fabpat design did not write"
    return None


def check_design_out(out: str | os.PathLike[str]) -> Path:
    """The output folder, if it is missing, empty or an earlier design output (:func:`design_in_the_way`);
    ExportError otherwise."""
    p = Path(out)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ExportError(f"cannot write {p}: folder {parent} does not exist")
    why = design_in_the_way(p)
    if why is not None:
        raise ExportError(f"--out {p} exists and {why}: remove or move it, or choose a new folder")
    return p


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a JSON string is a valid TOML basic string
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise ExportError(f"cannot write {v!r} to design.toml")


def spec_toml(data: dict[str, Any]) -> str:
    """TOML text of a decoded spec (top-level keys, then one table per section; values as inline TOML,
    except a table of a section, such as ``[patterns] tiles``, which gets its own ``[section.key]`` table
    with one key per line)."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            plain = [f"{kk} = {_toml_value(vv)}" for kk, vv in v.items() if not isinstance(vv, dict)]
            if plain or not v:
                lines += ["", f"[{k}]", *plain]
            for kk, vv in v.items():
                if isinstance(vv, dict):
                    lines += ["", f"[{k}.{kk}]"] + [f"{a} = {_toml_value(b)}" for a, b in vv.items()]
    return "\n".join(lines) + "\n"


def design_spec_data(res: Any) -> dict[str, Any]:
    """The base spec's tables with ``[patterns] tiles`` = every plate's pattern (and ``bridge_weight`` =
    the family member of every plate that is one) and, for a strip, ``[load] end_shortening`` = the
    design's."""
    from fabpat.design.base import split_member

    data = {k: v for k, v in res.base.data.items() if k not in ("patterns", "load")}
    members = {lab: split_member(c) for lab, c in res.record["patterns"].items()}
    data["patterns"] = {"tiles": {lab: pid for lab, (pid, _) in members.items()}}
    varied = {lab: w for lab, (_, w) in members.items() if w != 1.0}
    if varied:  # family members: each plate's bridge_weight (fabpat.patterns.variation); the others keep the paper's
        data["patterns"]["bridge_weight"] = varied
    if res.record.get("sleeve_angles"):  # a closed design's own angles (fabpat.design.closed_angles), in their range
        sleeve = dict(data.get("sleeve", {}))
        sleeve["angles"] = dict(res.record["sleeve_angles"])
        sleeve["angle_range"] = list(res.base.spec.sleeve.angle_range)
        data["sleeve"] = sleeve
    if "end_shortening" in res.record:
        data["load"] = {"end_shortening": float(res.record["end_shortening"])}
    return data


def write_closed_png(res: Any, path: Path) -> None:
    """The predicted closed shape's nodes coloured by their distance from the fitted target (mm), seen
    from two sides, and each group's pattern."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec, P, d = res.record, res.best.data["P"], res.best.fit.distance
    fig = plt.figure(figsize=(10, 5.0), dpi=120)
    c = P - P.mean(axis=0)
    vmax = float(d.max()) or 1.0
    for j, (elev, azim) in enumerate(((20, 30), (-20, 210))):
        ax = fig.add_axes((0.01 + 0.44 * j, 0.02, 0.44, 0.84), projection="3d")
        sc = ax.scatter(c[:, 0], c[:, 1], c[:, 2], c=d, s=1.2, cmap="viridis", vmin=0.0, vmax=vmax)
        ax.view_init(elev=elev, azim=azim)
        ax.set_box_aspect((1, 1, 1), zoom=1.35)
        lim = float(np.abs(c).max())
        for set_lim in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
            set_lim(-lim, lim)
        ax.set_axis_off()
    fig.colorbar(sc, cax=fig.add_axes((0.9, 0.2, 0.02, 0.55)), label="distance from the target, mm")
    groups = sorted(set(rec["patterns"].values()))
    fig.suptitle(f"{rec['target']}: rms {rec['rms_error']:.3g} mm ({rec['relative_rms']:.3%} of the radius "
                 f"{rec['radius']:.1f} mm), peak strain {rec['peak_strain']:.2%}\npatterns: {', '.join(groups)}",
                 fontsize=9)
    fig.savefig(path, format="png")
    plt.close(fig)


def write_png(res: Any, path: Path) -> None:
    """Target and predicted mid-lines, and each column's pattern (coloured by log-stiffness 1/U)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec, t, d = res.record, res.target, res.best.data
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(10, 4.6), dpi=120, gridspec_kw={"height_ratios": [3.2, 1]})
    ax.plot(t.x, t.z, "k--", lw=1.6, label="target")
    ax.plot(d["x"], d["z"], color="C3", lw=2, label=f"design: rms {rec['rms_error']:.2f} mm "
            f"({rec['relative_rms']:.2%} of the span)")
    if "single" in res.baseline_runs:
        s = res.baseline_runs["single"].data
        ax.plot(s["x"], s["z"], color="0.6", lw=1, label="best single pattern")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x from column 0's pin, mm")
    ax.set_ylabel("z, mm")
    ax.legend(fontsize=8, loc="lower center")
    columns = max(res.face_col) + 1
    ids = [rec["patterns"][res.labels[res.face_col.index(c)]] for c in range(columns)]
    e = res.base.energies
    logs = np.array([-math.log(e[i]) for i in ids])
    all_logs = -np.log(list(e.values()))
    lo, hi = float(all_logs.min()), float(all_logs.max())
    cmap = plt.get_cmap("viridis")
    for c, (pid, v) in enumerate(zip(ids, logs, strict=True)):
        bx.add_patch(plt.Rectangle((c, 0), 1, 1, color=cmap((v - lo) / max(hi - lo, 1e-12))))
        bx.text(c + 0.5, 0.5, pid, ha="center", va="center", rotation=90 if columns > 10 else 0, fontsize=7,
                color="white" if (v - lo) / max(hi - lo, 1e-12) < 0.6 else "black")
    bx.set_xlim(0, columns)
    bx.set_ylim(0, 1)
    bx.set_yticks([])
    bx.set_xlabel("column (colour: stiffness 1/U_cylinder, dark = soft)")
    fig.tight_layout()
    fig.savefig(path, format="png")
    plt.close(fig)


def write_design(res: Any, out: str | os.PathLike[str], kit: bool = False) -> list[str]:
    """Write the design's files into ``out`` atomically (module doc); returns their names in ``out``."""
    from fabpat.assembly.kit.folder import write_folder

    p = check_design_out(out)

    def write(tmp: Path) -> list[str]:
        (tmp / "design.toml").write_text(spec_toml(design_spec_data(res)), encoding="utf-8")
        for name, data in getattr(res, "files", {}).items():  # a mapped tiling's mesh, which design.toml names
            (tmp / name).write_bytes(data)
        record = {**res.record, "generator": GENERATOR}
        (tmp / "design.json").write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        (write_png if "end_shortening" in res.record else write_closed_png)(res, tmp / "design.png")
        files = list(FILES) + sorted(getattr(res, "files", {}))
        if kit:
            from fabpat.assembly.kit.build import assemble

            # predicted at the design's own mesh edge, so kit/prediction.json and design.json agree
            made = assemble(str(tmp / "design.toml"), tmp / "kit", predict_h=res.record.get("h"))
            files += [f"kit/{f}" for f in made.files]
        return files

    return write_folder(p, write, design_in_the_way)
