"""3D outputs of an assembly: STEP assembly, one STL per distinct part, GLB preview.

* STEP AP214 through OCCT's XDE document: one product per distinct part (named by
  :meth:`PartLibrary.name`, coloured as in ``assembly.png``), and per placed part a located
  instance named by its label ("H07", "E42") of a one-part product "H07 hex 0x0488" that holds the
  shared part, so a CAD program (FreeCAD included) shows a named assembly tree and the file holds
  each exact solid once (see :func:`write_step_assembly`).
* STL: each distinct part in its print orientation — plates flat (z from 0 to t), sleeves standing on
  an end face (:meth:`~fabpat.assembly.place.sleeve.Sleeve.print_transform`) — written by
  :func:`fabpat.exchange.stl.dump_stl`.
* GLB (binary glTF 2.0) by trimesh, in metres (glTF's unit): one mesh per distinct part with a PBR
  material in its ``assembly.png`` colour, one node per placed part referring to that mesh.

Writers here are not atomic on their own: :mod:`fabpat.assembly.kit.build` writes into a temporary
folder that becomes the output folder only when everything succeeded.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fabpat.assembly.place.parts import CHECK_TOLERANCE, PartLibrary, gp_trsf, transformed
from fabpat.errors import ExportError
from fabpat.exchange.cad import DEFAULT_CHORD

if TYPE_CHECKING:
    import trimesh
    from OCP.TDF import TDF_Label

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


def instance_product_name(label: str, key: str) -> str:
    """Name of the one-part product that places part ``key`` as ``label``: ``"H01 hex 0x0488"``."""
    return f"{label} {key}"


def write_step_assembly(lib: PartLibrary, path: str | os.PathLike[str], name: str,
                        timestamp: str | None = None,
                        placed: list[tuple[str, str, np.ndarray]] | None = None) -> None:
    """Write the placed parts as a STEP AP214 assembly (mm) with named products and instances.

    ``placed`` (label, part key, 4 × 4 transform) defaults to :meth:`PartLibrary.placed` (the assembled
    object); :func:`flat_layout` gives the distinct parts side by side instead (``parts.step``).

    Tree: the root product ``name`` → one instance per placed part, named by its label ("H01"),
    of a one-part product named :func:`instance_product_name` ("H01 hex 0x0488") → one instance,
    same label, of the shared part product (:meth:`PartLibrary.name`, exact solid, written once,
    coloured as in ``assembly.png``). The middle level is there for FreeCAD (0.20, default import
    settings): it labels every object by the name of the *product* it shows and collapses the
    instances of one product into a link array whose elements have no names, so instance names never
    show and its label renumbering mangles repeated product names ("… w0.2" → "… w0.003"). With one
    product per placed part, every FreeCAD object carries a unique label "H01 hex 0x0488".
    """
    from OCP.Quantity import Quantity_Color, Quantity_TypeOfColor
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_ColorType, XCAFDoc_DocumentTool

    from fabpat.exchange.step import write_document

    def named(label: TDF_Label, text: str) -> TDF_Label:
        TDataStd_Name.Set_s(label, TCollection_ExtendedString(text))
        return label

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 0.001)  # metres per model unit: the model is in mm
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    colour_tool = XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    root = named(tool.NewShape(), name)
    cols = colours(lib)
    protos = {}
    for key in lib.keys:
        protos[key] = named(tool.AddShape(lib.solid(key), False), lib.name(key))
        r, g, b = (int(cols[key][i:i + 2], 16) / 255 for i in (1, 3, 5))
        colour = Quantity_Color(r, g, b, Quantity_TypeOfColor.Quantity_TOC_sRGB)
        colour_tool.SetColor(protos[key], colour, XCAFDoc_ColorType.XCAFDoc_ColorGen)
    for label, key, T in lib.placed() if placed is None else placed:
        holder = named(tool.NewShape(), instance_product_name(label, key))
        named(tool.AddComponent(holder, protos[key], TopLoc_Location()), label)
        named(tool.AddComponent(root, holder, TopLoc_Location(gp_trsf(T))), label)
    tool.UpdateAssemblies()

    write_document(doc, path, name, timestamp)


#: mm between neighbouring parts of :func:`flat_layout`
LAYOUT_GAP = 10.0


def flat_layout(lib: PartLibrary, gap: float = LAYOUT_GAP) -> list[tuple[str, str, np.ndarray]]:
    """The distinct parts side by side along +X in print orientation (plates flat, z ∈ [0, t]; sleeves
    standing on an end face, :meth:`~fabpat.assembly.place.sleeve.Sleeve.print_transform`), ``gap`` mm apart,
    all on z = 0 and starting at y = 0: one (label ``"20x"``: how many the kit needs (ASCII: STEP names), part key,
    4 × 4 transform) per distinct part, for :func:`write_step_assembly` and the 3DM writer."""
    from fabpat.assembly.place.parts import PICTURE_TOLERANCE, apply

    counts = lib.assembly.counts()
    out, x = [], 0.0
    for key in lib.keys:
        orient = np.eye(4) if lib.is_plate(key) else lib.assembly.sleeve_types[key].print_transform()
        V = apply(orient, lib.mesh(key, PICTURE_TOLERANCE)[0])
        lo, hi = V.min(axis=0), V.max(axis=0)
        T = np.eye(4)
        T[:3, 3] = [x - lo[0], -lo[1], -lo[2]]
        out.append((f"{counts[key]}x", key, T @ orient))
        x += float(hi[0] - lo[0]) + gap
    return out


def read_step_tree(path: str | os.PathLike[str]) -> tuple[str, list[tuple[str, str, str]], int]:
    """Re-import a STEP assembly with OCCT's XDE reader, as CAD programs built on OCCT do.

    Returns (root product name, one (instance name, its product's name, the name of the part product
    that product holds, or "" if it holds a solid itself) per component of the root, number of
    located solids). Raises :class:`ExportError` if the file cannot be read.
    """
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDF import TDF_ChildIterator, TDF_Label
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.XCAFDoc import XCAFDoc_DocumentTool, XCAFDoc_ShapeTool

    def name_of(label: TDF_Label) -> str:
        attr = TDataStd_Name()
        return attr.Get().ToExtString() if label.FindAttribute(TDataStd_Name.GetID_s(), attr) else ""

    def components(label: TDF_Label) -> list[TDF_Label]:
        out, it = [], TDF_ChildIterator(label, False)
        while it.More():
            if XCAFDoc_ShapeTool.IsComponent_s(it.Value()):
                out.append(it.Value())
            it.Next()
        return out

    def referred(comp: TDF_Label) -> TDF_Label:
        ref = TDF_Label()
        XCAFDoc_ShapeTool.GetReferredShape_s(comp, ref)
        return ref

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    if reader.ReadFile(os.fsdecode(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise ExportError(f"cannot read STEP file {path}")
    if not reader.Transfer(doc):
        raise ExportError(f"cannot transfer STEP file {path}")
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    roots = []
    top = TDF_ChildIterator(tool.BaseLabel(), False)
    while top.More():
        if XCAFDoc_ShapeTool.IsFree_s(top.Value()) and XCAFDoc_ShapeTool.IsShape_s(top.Value()):
            roots.append(top.Value())
        top.Next()
    if len(roots) != 1:
        raise ExportError(f"{path}: expected one top-level product, found {len(roots)}")
    solids = 0
    ex = TopExp_Explorer(XCAFDoc_ShapeTool.GetShape_s(roots[0]), TopAbs_SOLID)
    while ex.More():
        solids += 1
        ex.Next()
    rows = []
    for comp in components(roots[0]):
        product = referred(comp)
        inner = components(product)
        rows.append((name_of(comp), name_of(product), name_of(referred(inner[0])) if inner else ""))
    return name_of(roots[0]), rows, solids


def read_step_solids(path: str | os.PathLike[str]) -> tuple[int, list[str]]:
    """Re-import a STEP file: (number of located solids, names of the assembly's components)."""
    _, rows, solids = read_step_tree(path)
    return solids, [row[0] for row in rows]


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


GLB_UNIT = 0.001  # metres per mm: glTF 2.0's unit of length is the metre (spec §3.4)
GLB_METALLIC = 0.0  # printed and cut polymer: a dielectric
GLB_ROUGHNESS = 0.6  # matte plastic


# glTF is y-up (glTF 2.0 §3.4: "+Y is up"); fabpat's models are z-up (plates flat in xy). Every GLB's
# root node carries this turn, (x, y, z) → (x, z, −y), −90° about x, so Blender and other viewers show
# a panel lying flat and a dome's apex up, with the vertices left in the model's own frame.
Y_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def glb_bytes(sc: trimesh.Scene) -> bytes:
    """Binary glTF 2.0 of the ``trimesh.Scene`` ``sc`` (metres, z up) that has one top node: that node gets
    the z-up → y-up turn :data:`Y_UP` (4 × 4) and no normals are written (viewers then shade every
    triangle flat, glTF 2.0 §3.7.2.1, which keeps the parts' sharp edges sharp). Every kit GLB is written
    here."""
    (root,) = sc.graph.transforms.children[sc.graph.base_frame]
    sc.graph.update(frame_from=sc.graph.base_frame, frame_to=root, matrix=Y_UP)
    data: bytes = sc.export(file_type="glb", include_normals=False)
    return data


def srgb_to_linear(hex_colour: str) -> list[float]:
    """``"#rrggbb"`` → linear RGB in [0, 1], as glTF's ``baseColorFactor`` wants it.

    glTF 2.0 §3.9.2: the base colour factor is linear; a viewer shows it through the sRGB transfer
    function, so the display colour is the hex colour of ``assembly.png``. Inverse sRGB transfer
    function from IEC 61966-2-1.
    """
    c = np.array([int(hex_colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    return [float(v) for v in np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)]


def scene(lib: PartLibrary, tolerance: float = CHECK_TOLERANCE) -> trimesh.Scene:
    """A ``trimesh.Scene`` of the assembled object in metres (z up, as the model; :func:`glb_bytes` turns it
    y-up when it is written): one mesh per distinct part, instanced.

    Each part key's mesh is stored once (vertices in m) with a PBR material in the part's colour of
    :func:`colours` (``assembly.png``); every placed part is a node named by its label ("H07",
    "SE42") under one root node named after the assembly, carrying its rigid transform (translation
    in m) and referring to that shared mesh.
    """
    import trimesh
    from trimesh.visual.material import PBRMaterial

    sc = trimesh.Scene()
    root = lib.assembly.spec.name or "assembly"
    if root in {label for label, _, _ in lib.placed()}:
        root += " assembly"
    sc.graph.update(frame_from=sc.graph.base_frame, frame_to=root, matrix=np.eye(4))
    cols = colours(lib)
    for key in lib.keys:
        V, F = lib.mesh(key, tolerance)
        m = trimesh.Trimesh(V * GLB_UNIT, F, process=False)
        material = PBRMaterial(name=slug(lib.name(key)), baseColorFactor=[*srgb_to_linear(cols[key]), 1.0],
                               metallicFactor=GLB_METALLIC, roughnessFactor=GLB_ROUGHNESS)
        m.visual = trimesh.visual.TextureVisuals(material=material)
        sc.geometry[slug(key)] = m
    for label, key, T in lib.placed():
        M = np.array(T, dtype=np.float64)
        M[:3, 3] *= GLB_UNIT
        sc.graph.update(frame_from=root, frame_to=label, matrix=M, geometry=slug(key))
    return sc


def write_glb(lib: PartLibrary, path: str | os.PathLike[str]) -> None:
    """The assembled object as binary glTF 2.0 in metres (see :func:`scene`).

    Written by :func:`glb_bytes`: y-up (glTF's convention), no normals. Raises
    :class:`fabpat.io.WriteFailed` (an :class:`ExportError`) if the file cannot be written.
    """
    from fabpat.io import writer_failed

    data = glb_bytes(scene(lib))
    try:
        Path(path).write_bytes(data)
    except OSError as exc:
        raise writer_failed(path, "cannot write the GLB file", exc) from exc


def write_3dm(lib: PartLibrary, path: str | os.PathLike[str], mesh_tolerance: float,
              placed: list[tuple[str, str, np.ndarray]] | None = None, *, timestamp: str | None = None) -> None:
    """The kit's parts as one Rhino ``.3dm`` (:func:`fabpat.exchange.rhino.write_assembly`): a block per
    part type in its :func:`colours`, plates exact, sleeves as meshes within ``mesh_tolerance`` (mm).

    ``placed`` (label, part key, 4 × 4 transform) defaults to the assembled object
    (:meth:`~fabpat.assembly.place.parts.PartLibrary.placed`); :func:`flat_layout` lays the distinct parts out
    flat instead. With ``timestamp`` (ISO 8601) the file is byte-reproducible. Raises :class:`ExportError`.
    """
    from fabpat.exchange.rhino import Block, write_assembly

    cols = colours(lib)
    blocks = []
    for key in lib.keys:
        rgb = (int(cols[key][1:3], 16), int(cols[key][3:5], 16), int(cols[key][5:7], 16))
        pt = lib.plate_type(key)
        if pt is None:
            blocks.append(Block(key, lib.name(key), rgb, mesh=lib.mesh(key, mesh_tolerance)))
        else:
            blocks.append(Block(key, lib.name(key), rgb, outline=lib.filleted[pt].outline,
                                thickness=lib.assembly.type_thickness(pt)))
    write_assembly(blocks, lib.placed() if placed is None else placed, path, timestamp=timestamp)
