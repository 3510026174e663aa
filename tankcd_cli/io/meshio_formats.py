"""Mesh formats read straight through meshio (VTK, VTU, Gmsh, XDMF, MED, Abaqus, ...), as
trimesh itself recommends for meshio's formats."""

from __future__ import annotations

import os
import tempfile

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.file_mesh import FileMesh, short_message

SUFFIXES = ("vtk", "vtu", "msh", "mesh", "xdmf", "xmf", "med", "inp", "dat", "tec", "ugrid", "su2", "avs", "f3grid", "wkt")


_VOLUME_CELLS = ("tetra", "hexahedron", "wedge", "pyramid", "polyhedron")


def _cell_description(kind: str) -> str:
    if kind.startswith("line"):
        return "line cells"
    if kind == "vertex":
        return "vertex cells (points)"
    if kind.startswith(_VOLUME_CELLS):
        return f"{kind} cells (volume, not a surface)"
    return f"{kind} cells"


def read_meshio(path: str, data: bytes, fmt: str, name: str) -> FileMesh:
    """A mesh through meshio: triangles (higher-order ones by their corners), quads and polygons
    as fans; line, vertex and volume cells left out and counted."""
    import meshio

    tmp = None
    if path == "-":  # meshio reads from paths; give it one
        fd, tmp = tempfile.mkstemp(suffix="." + fmt)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        path = tmp
    try:
        mesh = meshio.read(path, file_format=None if tmp is None else _MESHIO_NAMES.get(fmt))
    except Exception as exc:
        raise InputError(name, f"cannot read as {fmt.upper()}: {short_message(exc)}") from None
    finally:
        if tmp is not None:
            os.unlink(tmp)
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim == 2 and points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    tris = []
    skipped: dict[str, int] = {}
    for block in mesh.cells:
        cells = np.asarray(block.data, dtype=np.int64)
        if cells.ndim != 2 or len(cells) == 0:
            continue
        kind = block.type
        if kind in ("triangle", "triangle6", "triangle7"):  # higher-order: the corner nodes come first
            tris.append(cells[:, :3])
        elif kind in ("quad", "quad8", "quad9"):
            tris += [cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]]
        elif kind == "polygon" and cells.shape[1] >= 3:
            tris += [cells[:, [0, j, j + 1]] for j in range(1, cells.shape[1] - 1)]
        else:
            what = _cell_description(kind)
            skipped[what] = skipped.get(what, 0) + len(cells)
    faces = np.concatenate(tris) if tris else np.empty((0, 3), dtype=np.int64)
    return FileMesh(points, faces, skipped)


_MESHIO_NAMES = {"vtk": "vtk", "vtu": "vtu", "msh": "gmsh", "mesh": "medit", "xdmf": "xdmf", "xmf": "xdmf",
                 "med": "med", "inp": "abaqus", "dat": "tecplot", "tec": "tecplot", "ugrid": "ugrid", "su2": "su2",
                 "avs": "avsucd", "f3grid": "flac3d", "wkt": "wkt"}
