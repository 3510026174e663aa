"""Terrain readers: a registry keyed by file suffix, returning plain arrays.

``read_terrain`` chooses the reader by suffix (or ``fmt``) and returns a :class:`RawTerrain`
in the world frame (x east, y north, z up, metres, float64). The readers, by format family:
``obj.py`` (OBJ, its objects or groups as parts), ``gltf.py`` (glTF/GLB as a scene, node by
node, so external buffers resolve beside the file and node names become parts; Collada too
when trimesh's optional loader pycollada is installed), ``trimesh_formats.py`` (PLY, STL,
OFF), ``meshio_formats.py`` (VTK, VTU, Gmsh, XDMF, ..., straight through meshio, as trimesh
itself recommends for meshio's formats) and ``esri_ascii.py`` (ESRI ASCII grids, keeping the
grid structure for O(1) height queries later on).

What a surface cannot use but the writing program put there on purpose (OBJ
line and point elements and faces of fewer than three vertices, glTF line and
point primitives, meshio line, vertex and volume cells) is left out and counted
in ``RawTerrain.skipped``; what is broken (unparseable numbers, indices out of
range, non-finite coordinates) is an InputError.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
from dataclasses import dataclass, field

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostVertices
from tankcd_cli.io import esri_ascii, gltf, meshio_formats, trimesh_formats
from tankcd_cli.io.file_mesh import FileMesh
from tankcd_cli.io.files import read_bytes
from tankcd_cli.io.obj import read_obj

TRIMESH_SUFFIXES = ("obj",) + trimesh_formats.SUFFIXES + ("glb", "gltf")  # OBJ and glTF have readers of their own
MESHIO_SUFFIXES = meshio_formats.SUFFIXES
GRID_SUFFIXES = esri_ascii.SUFFIXES
COLLADA_SUFFIXES = ("dae",)  # only with pycollada (trimesh's optional loader)
IMAGE_SUFFIXES = ("png", "jpg", "jpeg", "bmp")  # refused with advice; heightmaps and rasters are read elsewhere
Y_UP_FORMATS = gltf.GLTF_SUFFIXES  # y-up by their specification

COLLADA_UNSUPPORTED = "Collada is not supported here: convert it to GLB or OBJ (e.g. in Blender)"
IMAGE_NOT_A_MESH = ("an image, not a mesh: a heightmap goes through classify as an 8- or 16-bit grey PNG or a RAW "
                    "(with --spacing), a GeoTIFF or an ESRI ASCII grid")


@dataclass(frozen=True)
class RawTerrain:
    """A terrain (or any mesh) as read.

    vertices : (n, 3) float64, m, world frame (z up, whatever the file's convention)
    faces : (m, 3) int64 -- triangles; polygons are split into fans from their first vertex
    grid : PostVertices or None -- the raster structure of a DEM: its PostGrid and the vertex of each post
    source, sha256, format : the file's name as given, the SHA-256 of its bytes (of the
        .gltf itself, not of its external buffers), the format read (the suffix or ``fmt``)
    up : "z" or "y" -- the up axis actually applied: a y-up file was turned +90 deg about x
        ((x, y, z) -> (x, -z, y)) into z-up
    skipped : {description: count} -- what the file holds that a surface cannot use and
        was left out, e.g. {"faces with fewer than 3 vertices": 201, "line elements": 3,
        "point elements": 1}; counts are elements as the file has them (OBJ lines, glTF
        primitive instances, meshio cells). Empty when nothing was left out.
    face_part : (m,) int32 or None -- per triangle, its index into ``part_names``; None when
        the file names no parts (an OBJ without ``o``/``g`` lines, a glTF whose nodes and
        meshes have no names, PLY, STL, OFF, meshio formats, DEMs)
    part_names : tuple of str -- the parts in order of their first triangle, each named
        once (repeated names are one part). OBJ: the ``o`` object names, or the ``g``
        group names when the file has no objects; triangles outside any are "default".
        glTF/GLB: the names of the nodes carrying the meshes (a node without a name takes its
        mesh's, and without either is "node <i>", its index in the file); Collada: the scene's
        node names. Empty when
        ``face_part`` is None.
    """

    vertices: np.ndarray
    faces: np.ndarray
    grid: PostVertices | None
    source: str
    sha256: str
    format: str
    up: str = "z"
    skipped: dict = field(default_factory=dict)
    face_part: np.ndarray | None = None
    part_names: tuple = ()


def _collada_available() -> bool:
    try:
        return importlib.util.find_spec("collada") is not None
    except (ImportError, ValueError):
        return False


def known_formats() -> tuple[str, ...]:
    collada = COLLADA_SUFFIXES if _collada_available() else ()
    return GRID_SUFFIXES + TRIMESH_SUFFIXES + collada + MESHIO_SUFFIXES


def default_up(fmt: str, data: bytes | None = None) -> str:
    """The up axis of a format's own convention: "y" for glTF/GLB (their specification),
    Collada's ``<up_axis>`` (Y_UP when absent, as its specification says), "z" for the rest."""
    if fmt in Y_UP_FORMATS:
        return "y"
    if fmt in COLLADA_SUFFIXES and data is not None:
        m = re.search(rb"<up_axis>\s*([XYZ])_UP\s*</up_axis>", data[:65536])
        return "y" if m is None or m.group(1) == b"Y" else "z"  # X_UP, rare, is not turned
    return "z"


def read_terrain(path: str, up: str | None = None, fmt: str | None = None) -> RawTerrain:
    """Read a terrain mesh or DEM.

    path : file path, or "-" for standard input (then ``fmt`` is required)
    up : "z", "y" or None (default): the format's own convention (``default_up``): "y" for
        glTF/GLB, "z" for the others and always for DEM grids. A y-up mesh is turned
        +90 deg about x into z-up.
    fmt : format name overriding the suffix (e.g. "obj", "asc")
    """
    name = "<stdin>" if path == "-" else path
    if fmt is None:
        if path == "-":
            raise InputError(name, "reading a terrain from standard input needs --format")
        fmt = os.path.splitext(path)[1].lower().lstrip(".")
        if path.lower().endswith(".tar.gz"):
            fmt = "tar.gz"
    fmt = fmt.lower()
    if path != "-" and not os.path.exists(path):  # before the format: a missing store is not an unknown format
        raise InputError(name, "no such file")
    if fmt in IMAGE_SUFFIXES:
        raise InputError(name, IMAGE_NOT_A_MESH)
    if fmt in COLLADA_SUFFIXES and not _collada_available():
        raise InputError(name, COLLADA_UNSUPPORTED)
    if fmt not in known_formats():
        raise InputError(name, f"unknown terrain format {fmt!r}; known: {', '.join(known_formats())}, h5 (a store)")
    if up not in (None, "z", "y"):
        raise InputError(name, f"unknown up axis {up!r}; use z or y")
    data = read_bytes(path, name)
    if not data.strip():
        raise InputError(name, "file is empty")
    digest = hashlib.sha256(data).hexdigest()
    if fmt in GRID_SUFFIXES:
        vertices, faces, grid = esri_ascii.parse_esri_ascii(data, name)
        mesh = FileMesh(vertices, faces)
        if up is None:
            up = "z"
    else:
        grid = None
        if fmt == "obj":
            mesh = read_obj(data, name)
        elif fmt in ("gltf", "glb") or fmt in COLLADA_SUFFIXES:
            mesh = gltf.read_scene(path, data, fmt, name)
        elif fmt in TRIMESH_SUFFIXES:
            mesh = trimesh_formats.read_trimesh(data, fmt, name)
        else:
            mesh = meshio_formats.read_meshio(path, data, fmt, name)
        if up is None:
            up = default_up(fmt, data)
    vertices, faces = mesh.vertices, mesh.faces
    if up == "y":
        if grid is not None:
            raise InputError(name, "--up y makes no sense for a DEM grid (grids are z-up)")
        vertices = np.column_stack([vertices[:, 0], -vertices[:, 2], vertices[:, 1]])
    if len(faces) == 0 and mesh.skipped:
        left_out = ", ".join(f"{count} {what}" for what, count in mesh.skipped.items())
        raise InputError(name, f"no triangle faces (a terrain needs a surface, not points or lines; left out: {left_out})")
    _check_arrays(vertices, faces, name)
    face_part = mesh.face_part
    if face_part is not None:
        face_part = np.asarray(face_part, dtype=np.int32)
    return RawTerrain(vertices, faces, grid, name, digest, fmt, up, dict(mesh.skipped), face_part,
                      tuple(mesh.part_names) if face_part is not None else ())


MAX_COORDINATE = 1e9  # m


def _check_arrays(vertices: np.ndarray, faces: np.ndarray, name: str) -> None:
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise InputError(name, "no vertices")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise InputError(name, "no triangle faces (a terrain needs a surface, not points or lines)")
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(name, f"non-finite coordinate {vertices[i].tolist()} ({int(bad.sum())} such vertices)", where=f"vertex {i + 1}")
    # no terrain in metres reaches a million kilometres; such numbers are a unit or parse error
    # (and would overflow the squared distances of the neighbour searches)
    huge = (np.abs(vertices) > MAX_COORDINATE).any(axis=1)
    if huge.any():
        i = int(np.flatnonzero(huge)[0])
        raise InputError(name, f"coordinate beyond {MAX_COORDINATE:.0e} m {vertices[i].tolist()} "
                               f"({int(huge.sum())} such vertices)", where=f"vertex {i + 1}")
    out = (faces < 0) | (faces >= len(vertices))
    if out.any():
        i = int(np.flatnonzero(out.any(axis=1))[0])
        raise InputError(name, f"vertex index out of range (the file has {len(vertices)} vertices)", where=f"face {i + 1}")

