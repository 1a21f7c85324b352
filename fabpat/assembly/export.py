"""3D outputs of an assembly: STEP assembly, one STL per distinct part, GLB preview.

* STEP AP214 through OCCT's XDE document: one product per distinct part (named by
  :meth:`PartLibrary.name`), one located component per placed part named by its label ("H07",
  "SE42"), so a CAD program shows a named assembly tree and the file holds each exact solid once.
* STL: each distinct part in its print orientation — plates flat (z from 0 to t), sleeves standing on
  an end face (:meth:`~fabpat.assembly.sleeve.Sleeve.print_transform`) — written by
  :func:`fabpat.exchange.stl.dump_stl`.
* GLB (binary glTF 2.0) by trimesh: one mesh per distinct part, one node per placed part.

Writers here are not atomic on their own: :mod:`fabpat.assembly.build` writes into a temporary
folder that becomes the output folder only when everything succeeded.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from fabpat.assembly.parts import CHECK_TOLERANCE, PartLibrary, gp_trsf, transformed
from fabpat.cad import DEFAULT_CHORD
from fabpat.errors import ExportError

PALETTE = ["#f2a541", "#4a90d9", "#7bc67b", "#d96c6c", "#a57fd1", "#5cc4c4", "#c9b458"]
SLEEVE_COLOUR = "#5a5a5a"


def slug(text: str) -> str:
    """A file-name-safe version of a part key: ``"hex 0x0488"`` → ``"hex-0x0488"``."""
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-")


def colours(lib: PartLibrary) -> dict[str, str]:
    """Display colour of each part key: a palette colour per plate type, grey for sleeves."""
    out = {}
    for i, pt in enumerate(lib.assembly.plate_types):
        out[pt.label] = PALETTE[i % len(PALETTE)]
    for key in lib.assembly.sleeve_types:
        out[key] = SLEEVE_COLOUR
    return out


def write_step_assembly(lib: PartLibrary, path: str | os.PathLike[str], name: str,
                        timestamp: str | None = None) -> None:
    """Write the placed parts as a STEP AP214 assembly (mm) with named products and instances."""
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    from fabpat.exchange.step import write_document

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 0.001)  # metres per model unit: the model is in mm
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    root = tool.NewShape()
    TDataStd_Name.Set_s(root, TCollection_ExtendedString(name))
    protos = {}
    for key in lib.keys:
        protos[key] = tool.AddShape(lib.solid(key), False)
        TDataStd_Name.Set_s(protos[key], TCollection_ExtendedString(lib.name(key)))
    for label, key, T in lib.placed():
        comp = tool.AddComponent(root, protos[key], TopLoc_Location(gp_trsf(T)))
        TDataStd_Name.Set_s(comp, TCollection_ExtendedString(label))
    tool.UpdateAssemblies()

    write_document(doc, path, name, timestamp)


def read_step_solids(path: str | os.PathLike[str]) -> tuple[int, list[str]]:
    """Re-import a STEP file: (number of located solids, names of the assembly's components)."""
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDF import TDF_ChildIterator
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.XCAFDoc import XCAFDoc_DocumentTool, XCAFDoc_ShapeTool

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    if reader.ReadFile(os.fsdecode(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise ExportError(f"cannot read STEP file {path}")
    if not reader.Transfer(doc):
        raise ExportError(f"cannot transfer STEP file {path}")
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    count, names = 0, []
    top = TDF_ChildIterator(tool.BaseLabel(), False)
    while top.More():
        label = top.Value()
        top.Next()
        if not (XCAFDoc_ShapeTool.IsFree_s(label) and XCAFDoc_ShapeTool.IsShape_s(label)):
            continue
        ex = TopExp_Explorer(XCAFDoc_ShapeTool.GetShape_s(label), TopAbs_SOLID)
        while ex.More():
            count += 1
            ex.Next()
        child = TDF_ChildIterator(label, False)
        while child.More():
            comp = child.Value()
            child.Next()
            attr = TDataStd_Name()
            if XCAFDoc_ShapeTool.IsComponent_s(comp) and comp.FindAttribute(TDataStd_Name.GetID_s(), attr):
                names.append(attr.Get().ToExtString())
    return count, names


def write_part_stls(lib: PartLibrary, folder: Path, tolerance: float = DEFAULT_CHORD) -> dict[str, Path]:
    """One binary STL per distinct part in print orientation; returns {part key: path}."""
    from fabpat.exchange.stl import dump_stl

    out = {}
    for key in lib.keys:
        shape = lib.solid(key)
        if not lib.is_plate(key):
            shape = transformed(shape, lib.assembly.sleeve_types[key].print_transform())
        kind = "plate" if lib.is_plate(key) else "sleeve"
        path = folder / f"{kind}-{slug(key)}.stl"
        dump_stl(shape, path, tolerance)
        out[key] = path
    return out


def scene(lib: PartLibrary, tolerance: float = CHECK_TOLERANCE):  # type: ignore[no-untyped-def]
    """A ``trimesh.Scene`` of the assembled object: shared geometry per part, one node per placement."""
    import trimesh

    sc = trimesh.Scene()
    cols = colours(lib)
    geoms = {}
    for key in lib.keys:
        V, F = lib.mesh(key, tolerance)
        rgba = [int(cols[key][i:i + 2], 16) for i in (1, 3, 5)] + [255]
        m = trimesh.Trimesh(V, F, process=False)
        m.visual = trimesh.visual.ColorVisuals(m, face_colors=np.tile(rgba, (len(F), 1)).astype(np.uint8))
        geoms[key] = m
    for label, key, T in lib.placed():
        sc.add_geometry(geoms[key], node_name=label, geom_name=slug(key), transform=T)
    return sc


def write_glb(lib: PartLibrary, path: str | os.PathLike[str]) -> None:
    """The assembled object as binary glTF (mm, as glTF has no units: 1 unit = 1 mm)."""
    data = scene(lib).export(file_type="glb")
    Path(path).write_bytes(data)
