"""Terrain readers: a registry keyed by file suffix, returning plain arrays.

Every reader returns a :class:`RawTerrain` in the world frame (x east, y north,
z up, metres, float64). OBJ has its own reader (which also keeps the file's
objects or groups as parts); PLY, STL, OFF and glTF/GLB go through trimesh
(glTF/GLB as a scene, node by node, so external buffers resolve beside the file
and node names become parts); Collada too when trimesh's optional loader
(pycollada) is installed; VTK, VTU, Gmsh, XDMF, ... go straight through meshio,
as trimesh itself recommends for meshio's formats; ESRI ASCII grids have their
own reader that keeps the grid structure for O(1) height queries later on.

What a surface cannot use but the writing program put there on purpose (OBJ
line and point elements and faces of fewer than three vertices, glTF line and
point primitives, meshio line, vertex and volume cells) is left out and counted
in ``RawTerrain.skipped``; what is broken (unparseable numbers, indices out of
range, non-finite coordinates) is an InputError.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import re
import struct
from dataclasses import dataclass, field

import numpy as np

from tankcd_cli.errors import InputError

TRIMESH_SUFFIXES = ("obj", "ply", "stl", "off", "glb", "gltf")
MESHIO_SUFFIXES = ("vtk", "vtu", "msh", "mesh", "xdmf", "xmf", "med", "inp", "dat", "tec", "ugrid", "su2", "avs", "f3grid", "wkt")
GRID_SUFFIXES = ("asc",)
COLLADA_SUFFIXES = ("dae",)  # only with pycollada (trimesh's optional loader)
IMAGE_SUFFIXES = ("png", "jpg", "jpeg", "bmp")  # refused with advice; tif/tiff are rasters, read elsewhere
Y_UP_FORMATS = ("gltf", "glb")  # y-up by their specification

COLLADA_UNSUPPORTED = "Collada is not supported here: convert it to GLB or OBJ (e.g. in Blender)"
IMAGE_NOT_A_MESH = ("an image, not a mesh: a height map goes through classify as a raster (GeoTIFF) "
                    "or an ESRI ASCII grid")


@dataclass(frozen=True)
class Grid:
    """A regular raster of posts (vertices at cell centres).

    origin : (2,) float, m -- world x, y of post (row 0, column 0), the south-west one
    spacing : (2,) float, m -- post spacing along x (columns) and y (rows)
    vertex : (nrows, ncols) int64 -- vertex index of each post, -1 for NODATA;
        row index grows northwards.
    """

    origin: np.ndarray
    spacing: np.ndarray
    vertex: np.ndarray


@dataclass(frozen=True)
class RawTerrain:
    """A terrain (or any mesh) as read.

    vertices : (n, 3) float64, m, world frame (z up, whatever the file's convention)
    faces : (m, 3) int64 -- triangles; polygons are split into fans from their first vertex
    grid : Grid or None -- the raster structure of a DEM
    source, sha256, format : the file's name as given, the SHA-256 of its bytes (of the
        .gltf itself, not of its external buffers), the format read (the suffix or ``fmt``)
    up : "z" or "y" -- the up axis actually applied: a y-up file was turned +90 deg about x
        ((x, y, z) -> (x, -z, y)) into z-up
    skipped : {description: count} -- what the file holds that a surface cannot use and
        was left out, e.g. {"faces with fewer than 3 vertices": 201, "line elements": 3,
        "point elements": 1}; counts are elements as the file has them (OBJ lines, glTF
        primitive instances, meshio cells). Empty when nothing was left out.
    face_part : (m,) int32 or None -- per triangle, its index into ``part_names``; None when
        the file names no parts (an OBJ without ``o``/``g`` lines, a glTF whose nodes have
        no names, PLY, STL, OFF, meshio formats, DEMs)
    part_names : tuple of str -- the parts in order of their first triangle, each named
        once (repeated names are one part). OBJ: the ``o`` object names, or the ``g``
        group names when the file has no objects; triangles outside any are "default".
        glTF/GLB: the names of the nodes carrying the meshes (a node without a name is
        "node <i>", its index in the file); Collada: the scene's node names. Empty when
        ``face_part`` is None.
    """

    vertices: np.ndarray
    faces: np.ndarray
    grid: Grid | None
    source: str
    sha256: str
    format: str
    up: str = "z"
    skipped: dict = field(default_factory=dict)
    face_part: np.ndarray | None = None
    part_names: tuple = ()


@dataclass
class _Mesh:
    """What a mesh reader returns: geometry in the file's own axes, what it left out, parts."""

    vertices: np.ndarray
    faces: np.ndarray
    skipped: dict = field(default_factory=dict)
    face_part: np.ndarray | None = None
    part_names: tuple = ()


def _collada_available() -> bool:
    import importlib.util

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
    data = _read_bytes(path, name)
    if not data.strip():
        raise InputError(name, "file is empty")
    digest = hashlib.sha256(data).hexdigest()
    if fmt in GRID_SUFFIXES:
        vertices, faces, grid = parse_esri_ascii(data, name)
        mesh = _Mesh(vertices, faces)
        if up is None:
            up = "z"
    else:
        grid = None
        if fmt == "obj":
            mesh = _read_obj(data, name)
        elif fmt in ("gltf", "glb") or fmt in COLLADA_SUFFIXES:
            mesh = _read_scene(path, data, fmt, name)
        elif fmt in TRIMESH_SUFFIXES:
            mesh = _read_trimesh(data, fmt, name)
        else:
            mesh = _read_meshio(path, data, fmt, name)
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


def _read_bytes(path: str, name: str) -> bytes:
    from tankcd_cli.io.files import open_input

    _, stream = open_input(path)
    try:
        return stream.read()
    except OSError as exc:
        raise InputError(name, f"cannot read: {exc.strerror or exc}") from None
    finally:
        if path != "-":
            stream.close()


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


# --- ESRI ASCII grid ---------------------------------------------------------

_HEADER_KEYS = {"ncols", "nrows", "xllcorner", "yllcorner", "xllcenter", "yllcenter", "cellsize", "dx", "dy", "nodata_value"}


def parse_esri_ascii(data: bytes, name: str) -> tuple[np.ndarray, np.ndarray, Grid]:
    """Parse an ESRI ASCII grid into posts, triangles and the grid structure.

    Posts sit at cell centres. A quad of four valid posts gives two triangles;
    a quad with exactly three valid posts gives the one triangle they span;
    NODATA posts are left out of the mesh.
    """
    z, valid, (x0, y0), (dx, dy) = esri_ascii_posts(data, name)
    nrows, ncols = z.shape
    vertex = np.full((nrows, ncols), -1, dtype=np.int64)
    vertex[valid] = np.arange(int(valid.sum()))
    yy, xx = np.nonzero(valid)
    vertices = np.column_stack([x0 + xx * dx, y0 + yy * dy, z[valid]])
    faces = grid_faces(vertex)
    if len(faces) == 0:
        raise InputError(name, "no cell has three valid posts: nothing to triangulate")
    grid = Grid(origin=np.array([x0, y0]), spacing=np.array([dx, dy]), vertex=vertex)
    return vertices, faces, grid


def esri_ascii_posts(data: bytes, name: str) -> tuple[np.ndarray, np.ndarray, tuple, tuple]:
    """Heights (rows, cols) float64 with row 0 SOUTH, the valid mask, the world x, y of the
    south-west post and the spacing (dx, dy) of an ESRI ASCII grid."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(name, "not a text file (an ESRI ASCII grid is text)") from None
    lines = text.splitlines()
    header: dict[str, str] = {}
    body_start = 0
    for lineno, line in enumerate(lines):
        tokens = line.split()
        if not tokens:
            continue
        key = tokens[0].lower()
        if key not in _HEADER_KEYS:
            break
        if len(tokens) != 2:
            raise InputError(name, f"header line must be 'key value', got {line.strip()!r}", where=f"line {lineno + 1}")
        if key in header:
            raise InputError(name, f"header key {tokens[0]} given twice", where=f"line {lineno + 1}")
        header[key] = tokens[1]
        body_start = lineno + 1
    for key in ("ncols", "nrows"):
        if key not in header:
            raise InputError(name, f"header lacks {key} (is this an ESRI ASCII grid?)")
    ncols = _header_int(header, "ncols", name)
    nrows = _header_int(header, "nrows", name)
    if "cellsize" in header:
        dx = dy = _header_float(header, "cellsize", name)
    elif "dx" in header and "dy" in header:
        dx, dy = _header_float(header, "dx", name), _header_float(header, "dy", name)
    else:
        raise InputError(name, "header lacks cellsize")
    if not (dx > 0 and dy > 0):
        raise InputError(name, "cellsize must be positive")
    if "xllcenter" in header:
        x0 = _header_float(header, "xllcenter", name)
    elif "xllcorner" in header:
        x0 = _header_float(header, "xllcorner", name) + dx / 2
    else:
        raise InputError(name, "header lacks xllcorner or xllcenter")
    if "yllcenter" in header:
        y0 = _header_float(header, "yllcenter", name)
    elif "yllcorner" in header:
        y0 = _header_float(header, "yllcorner", name) + dy / 2
    else:
        raise InputError(name, "header lacks yllcorner or yllcenter")
    nodata = _header_float(header, "nodata_value", name) if "nodata_value" in header else None

    tokens = " ".join(lines[body_start:]).split()
    expected = nrows * ncols
    if len(tokens) != expected:
        raise InputError(name, f"expected {nrows} x {ncols} = {expected} values after the header, found {len(tokens)}")
    try:
        z = np.array(tokens, dtype=np.float64)
    except ValueError:
        _locate_bad_token(lines, body_start, name)
        raise  # pragma: no cover - _locate_bad_token always raises
    z = z.reshape(nrows, ncols)[::-1]  # file lists the north row first; we index south to north
    if nodata is None:
        valid = np.ones(z.shape, dtype=bool)
    elif np.isnan(nodata):
        valid = ~np.isnan(z)
    else:
        valid = z != nodata
    nonfinite = valid & ~np.isfinite(z)
    if nonfinite.any():
        r, c = np.argwhere(nonfinite)[0]
        raise InputError(name, f"non-finite height {z[r, c]!r} (use NODATA_value for missing posts)",
                         where=f"row {nrows - r} column {c + 1}")
    if not valid.any():
        raise InputError(name, "every post is NODATA")
    if nrows < 2 or ncols < 2:
        raise InputError(name, f"a {nrows} x {ncols} grid has no cells to triangulate (needs at least 2 x 2 posts)")
    return z, valid, (x0, y0), (dx, dy)


def grid_faces(vertex: np.ndarray) -> np.ndarray:
    """Triangles (k, 3) over a post raster (-1 = missing), counter-clockwise seen from above.

    Full quads split along the SW-NE diagonal; quads with exactly three posts
    give the triangle of those three.
    """
    a = vertex[:-1, :-1]  # SW
    b = vertex[:-1, 1:]   # SE
    c = vertex[1:, 1:]    # NE
    d = vertex[1:, :-1]   # NW
    ok = np.stack([a >= 0, b >= 0, c >= 0, d >= 0])
    count = ok.sum(axis=0)
    full = count == 4
    tris = [np.column_stack([a[full], b[full], c[full]]), np.column_stack([a[full], c[full], d[full]])]
    three = count == 3
    # the triangle of the three valid corners, kept counter-clockwise
    for missing, corners in ((0, (b, c, d)), (1, (a, c, d)), (2, (a, b, d)), (3, (a, b, c))):
        sel = three & ~ok[missing]
        tris.append(np.column_stack([k[sel] for k in corners]))
    return np.concatenate(tris).astype(np.int64)


def _header_int(header: dict[str, str], key: str, name: str) -> int:
    try:
        value = int(header[key])
    except ValueError:
        raise InputError(name, f"header {key} must be a whole number, got {header[key]!r}") from None
    if value <= 0:
        raise InputError(name, f"header {key} must be positive, got {value}")
    return value


def _header_float(header: dict[str, str], key: str, name: str) -> float:
    try:
        value = float(header[key])
    except ValueError:
        raise InputError(name, f"header {key} must be a number, got {header[key]!r}") from None
    if not np.isfinite(value) and key != "nodata_value":
        raise InputError(name, f"header {key} must be finite, got {header[key]!r}")
    return value


def _locate_bad_token(lines: list[str], body_start: int, name: str) -> None:
    for lineno in range(body_start, len(lines)):
        for col, token in enumerate(lines[lineno].split()):
            try:
                float(token)
            except ValueError:
                raise InputError(name, f"not a number: {token[:40]!r}", where=f"line {lineno + 1} value {col + 1}") from None
    raise InputError(name, "unparseable grid values")


# --- meshes ------------------------------------------------------------------

SHORT_FACES = "faces with fewer than 3 vertices"
OBJ_LINES = "line elements"
OBJ_POINTS = "point elements"
DEFAULT_PART = "default"  # the OBJ specification's name for faces outside any group

_OBJ_KNOWN_PREFIXES = ("v ", "f ", "vt", "vn", "vp", "#", "s ", "usemtl", "mtllib", "l ", "p ", "o ", "g ")


def read_simple_obj(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and triangles of a plain OBJ (``v x y z`` and triangular ``f a b c``, indices
    with or without ``/vt/vn``), or None when the file needs a full reader (polygons, short
    faces, negative indices, unparseable or unusual lines). Saves importing anything (and a
    Python loop over the lines) for the common case. ``l`` and ``p`` elements and ``o``/``g``
    parts are left out here; ``_simple_obj`` counts and keeps them.
    """
    simple = _simple_obj(data)
    return None if simple is None else (simple.vertices, simple.faces)


def _simple_obj(data: bytes) -> _Mesh | None:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return None
    lines = text.splitlines()
    # a line this reader does not recognise (tabs after the keyword, leading blanks, continuation
    # lines, a bare "g") goes to the full reader rather than being dropped silently
    if any(ln.strip() for ln in lines if ln and not ln.startswith(_OBJ_KNOWN_PREFIXES)):
        return None
    if any(ln.endswith("\\") for ln in lines):
        return None
    v_lines = [ln[2:] for ln in lines if ln.startswith("v ")]
    f_lines = [ln[2:] for ln in lines if ln.startswith("f ")]
    if not v_lines or not f_lines:
        return None
    try:
        v_tokens = " ".join(v_lines).split()
        if len(v_tokens) != 3 * len(v_lines):  # colours, weights: let the full reader decide
            return None
        vertices = np.array(v_tokens, dtype=np.float64).reshape(-1, 3)
        f_tokens = " ".join(f_lines).split()
        if len(f_tokens) != 3 * len(f_lines):  # polygons, short faces
            return None
        if "/" in f_lines[0] or any("/" in t for t in f_tokens[:3]):
            f_tokens = [t.split("/", 1)[0] for t in f_tokens]
        faces = np.array(f_tokens, dtype=np.int64).reshape(-1, 3)
    except (ValueError, OverflowError):
        return None
    if (faces <= 0).any():  # relative (negative) indices: the full reader resolves them
        return None
    skipped = {}
    n_lines = sum(1 for ln in lines if ln.startswith("l "))
    n_points = sum(1 for ln in lines if ln.startswith("p "))
    if n_lines:
        skipped[OBJ_LINES] = n_lines
    if n_points:
        skipped[OBJ_POINTS] = n_points
    face_part, part_names = _simple_obj_parts(lines, len(f_lines))
    return _Mesh(vertices, faces - 1, skipped, face_part, part_names)


def _simple_obj_parts(lines: list[str], n_faces: int) -> tuple[np.ndarray | None, tuple]:
    """The parts of a plain OBJ (one triangle per ``f`` line), as ``parse_obj`` finds them:
    the ``o`` objects, else the ``g`` groups; (None, ()) when there are neither."""
    marks = [ln for ln in lines if ln.startswith(("o ", "g ", "f "))]
    if len(marks) == n_faces:
        return None, ()
    kind = np.frombuffer("".join(ln[0] for ln in marks).encode("ascii"), dtype=np.uint8)
    is_face = kind == ord("f")
    for key in ("o", "g"):
        is_key = kind == ord(key)
        if not is_key.any():
            continue
        ids: dict[str, int] = {}
        label_of_mark = np.array([ids.setdefault(ln[2:].strip() or DEFAULT_PART, len(ids))
                                  for ln in marks if ln[0] == key], dtype=np.int64)
        last = (np.cumsum(is_key) - 1)[is_face]  # per face, its latest key line (-1: none yet)
        labels = np.where(last >= 0, label_of_mark[np.maximum(last, 0)], -1)
        if (labels >= 0).any():
            return _compact_parts(labels, list(ids))
    return None, ()


def _read_obj(data: bytes, name: str) -> _Mesh:
    """An OBJ: the compiled reader, else the Python fast reader, when they suffice; the full one otherwise."""
    if data.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark would hide the first line's keyword
        data = data[3:]
    simple = _compiled_obj(data)
    if simple is None:
        simple = _simple_obj(data)
    return simple if simple is not None else parse_obj(data, name)


def _compiled_obj(data: bytes) -> _Mesh | None:
    """What ``_simple_obj`` gives, read by the compiled scanner (``obj_kernels``), or None when
    it declines the file (then ``_simple_obj`` and ``parse_obj`` decide, as without it; a face
    index past the last vertex is declined too, and refused as before by ``_check_arrays``)."""
    from tankcd_cli.io.obj_kernels import _POW10, scan_obj

    scanned = scan_obj(data, _POW10)
    if scanned is None:
        return None
    vertices, faces, n_lines, n_points, mark_kind, mark_faces, mark_start, mark_end = scanned
    skipped = {}
    if n_lines:
        skipped[OBJ_LINES] = n_lines
    if n_points:
        skipped[OBJ_POINTS] = n_points
    face_part, part_names = _marked_obj_parts(data, mark_kind, mark_faces, mark_start, mark_end, len(faces))
    return _Mesh(vertices, faces, skipped, face_part, part_names)


def _marked_obj_parts(data: bytes, kind: np.ndarray, faces_before: np.ndarray, start: np.ndarray,
                      end: np.ndarray, n_faces: int) -> tuple[np.ndarray | None, tuple]:
    """``_simple_obj_parts`` from the ``o``/``g`` marks alone (their kind, the number of faces
    before each, the byte range of each name): the ``o`` objects, else the ``g`` groups."""
    for key in (ord("o"), ord("g")):
        sel = np.flatnonzero(kind == key)
        if not len(sel):
            continue
        ids: dict[str, int] = {}
        label_of_mark = np.array([ids.setdefault(data[a:b].decode("utf-8").strip() or DEFAULT_PART, len(ids))
                                  for a, b in zip(start[sel].tolist(), end[sel].tolist())], dtype=np.int64)
        # per face, its latest mark of this kind (-1: none yet): the marks come in file order
        last = np.searchsorted(faces_before[sel], np.arange(n_faces), side="right") - 1
        labels = np.where(last >= 0, label_of_mark[np.maximum(last, 0)], -1)
        if (labels >= 0).any():
            return _compact_parts(labels, list(ids))
    return None, ()


def _obj_index(token: str, n_vertices: int) -> int | None:
    """0-based vertex index of a face token (``7``, ``7/2``, ``7//3``, ``-1/...``), resolving
    negative indices against the vertices read so far; None when not a usable index."""
    head = token.split("/", 1)[0]
    digits = head.removeprefix("-")
    if not (digits.isascii() and digits.isdigit()):
        return None
    i = int(head)
    if i == 0 or abs(i) >= 2**31:
        return None
    if i < 0:
        i += n_vertices
        return i if i >= 0 else None
    return i - 1


def parse_obj(data: bytes, name: str) -> _Mesh:
    """The full OBJ reader: vertices, faces (polygons as fans from their first vertex, as trimesh
    splits them), the ``o``/``g`` parts, and counts of what a surface cannot use: faces of fewer
    than three vertices, ``l`` and ``p`` elements. Other statements (texture coordinates,
    normals, materials, smoothing groups, free-form geometry) are ignored as every reader does.
    A vertex without three finite numbers or a face index that is not a number, zero, or out
    of range is an InputError naming the line.
    """
    text = data.decode("utf-8", errors="replace")
    if "\\\n" in text or "\\\r\n" in text:  # continuation lines
        text = re.sub(r"\\\r?\n", " ", text)
    coords: list[float] = []
    tris: list[int] = []
    tri_line: list[int] = []  # the line of each triangle, for messages
    tri_obj: list[int] = []
    tri_grp: list[int] = []
    objects: dict[str, int] = {}
    groups: dict[str, int] = {}
    cur_obj = cur_grp = -1
    n_vertices = 0
    short = n_lines = n_points = 0
    for number, line in enumerate(text.splitlines(), start=1):
        tokens = line.split()
        if not tokens:
            continue
        key = tokens[0]
        if key == "v":
            try:
                xyz = [float(t) for t in tokens[1:4]]
            except ValueError:
                xyz = []
            if len(xyz) < 3 or not all(math.isfinite(c) for c in xyz):
                raise InputError(name, f"a vertex needs three finite numbers: {line.strip()[:60]!r}", where=f"line {number}")
            coords += xyz
            n_vertices += 1
        elif key == "f":
            idx = [_obj_index(t, n_vertices) for t in tokens[1:]]
            if any(i is None for i in idx):
                raise InputError(name, f"a face's vertex indices are whole numbers from 1 (or negative, "
                                       f"counting back from the last vertex): {line.strip()[:60]!r}",
                                 where=f"line {number}")
            if len(idx) < 3:
                short += 1
                continue
            k = len(idx) - 2
            for j in range(1, len(idx) - 1):
                tris += (idx[0], idx[j], idx[j + 1])
            tri_line += [number] * k
            tri_obj += [cur_obj] * k
            tri_grp += [cur_grp] * k
        elif key == "l":
            n_lines += 1
        elif key == "p":
            n_points += 1
        elif key == "o":
            cur_obj = objects.setdefault(line.strip()[1:].strip() or DEFAULT_PART, len(objects))
        elif key == "g":
            cur_grp = groups.setdefault(line.strip()[1:].strip() or DEFAULT_PART, len(groups))
    vertices = np.array(coords, dtype=np.float64).reshape(-1, 3)
    faces = np.array(tris, dtype=np.int64).reshape(-1, 3)
    if len(faces):
        out = faces.max(axis=1) >= n_vertices
        if out.any():
            t = int(np.flatnonzero(out)[0])
            raise InputError(name, f"vertex index out of range (the file has {n_vertices} vertices)",
                             where=f"line {tri_line[t]}")
    skipped = {}
    for what, count in ((SHORT_FACES, short), (OBJ_LINES, n_lines), (OBJ_POINTS, n_points)):
        if count:
            skipped[what] = count
    face_part, part_names = None, ()
    for labels, names in ((tri_obj, objects), (tri_grp, groups)):
        if names and len(faces) and max(labels) >= 0:
            face_part, part_names = _compact_parts(np.array(labels, dtype=np.int64), list(names))
            break
    return _Mesh(vertices, faces, skipped, face_part, part_names)


def _compact_parts(labels: np.ndarray, names: list[str]) -> tuple[np.ndarray, tuple]:
    """Per-triangle labels (-1: outside any named part) renumbered to the parts that own
    triangles, in order of their first triangle; -1 becomes the part "default"."""
    names = names + [DEFAULT_PART]
    labels = np.where(labels < 0, len(names) - 1, labels)
    # one part per name: the unlabelled triangles join an explicit "default" if there is one
    canonical = {n: names.index(n) for n in names}
    labels = np.array([canonical[n] for n in names], dtype=np.int64)[labels]
    used, first = np.unique(labels, return_index=True)
    order = used[np.argsort(first)]
    remap = np.full(len(names), -1, dtype=np.int64)
    remap[order] = np.arange(len(order))
    return remap[labels].astype(np.int32), tuple(names[i] for i in order)


def _read_trimesh(data: bytes, fmt: str, name: str) -> _Mesh:
    import trimesh

    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=fmt, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed input
        raise InputError(name, f"cannot read as {fmt.upper()}: {_short(exc)}") from None
    vertices = np.asarray(getattr(loaded, "vertices", np.empty((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.empty((0, 3))), dtype=np.int64)
    return _Mesh(vertices.reshape(-1, 3), faces.reshape(-1, 3))


def _gltf_header(data: bytes, fmt: str) -> dict | None:
    """The JSON of a .gltf, or the JSON chunk of a .glb; None when it cannot be read (the
    loader then says what is wrong)."""
    try:
        if fmt == "glb":
            if data[:4] != b"glTF" or len(data) < 20:
                return None
            length, kind = struct.unpack_from("<I4s", data, 12)
            if kind != b"JSON":
                return None
            return json.loads(data[20:20 + length].decode("utf-8"))
        header = json.loads(data.decode("utf-8-sig"))
        return header if isinstance(header, dict) else None
    except (ValueError, UnicodeDecodeError, struct.error):
        return None


def _check_gltf_buffers(header: dict, path: str, name: str) -> None:
    """External buffers must be found: beside the file, and never from standard input."""
    from urllib.parse import unquote

    buffers = header.get("buffers") or []
    for i, buf in enumerate(buffers if isinstance(buffers, list) else []):
        uri = buf.get("uri") if isinstance(buf, dict) else None
        if not isinstance(uri, str) or uri.startswith("data:"):
            continue
        if path == "-":
            raise InputError(name, f"the buffer file {uri!r} cannot be found from standard input: "
                                   "give the .gltf's path, or convert it to GLB", where=f"buffer {i}")
        target = os.path.join(os.path.dirname(path), unquote(uri))
        if not os.path.isfile(target):
            raise InputError(name, f"the buffer file {uri!r} is missing (looked for {target})", where=f"buffer {i}")


def _read_scene(path: str, data: bytes, fmt: str, name: str) -> _Mesh:
    """glTF, GLB (and Collada): the scene's meshes with their node transforms applied, one
    part per named node; line and point primitives counted as skipped."""
    import trimesh

    header = None
    if fmt in Y_UP_FORMATS:
        header = _gltf_header(data, fmt)
        if header is not None:
            _check_gltf_buffers(header, path, name)
    resolver = None if path == "-" else trimesh.resolvers.FilePathResolver(os.path.abspath(path))
    try:
        scene = trimesh.load_scene(io.BytesIO(data), file_type=fmt, resolver=resolver, process=False)
    except Exception as exc:  # trimesh raises many types on malformed input
        raise InputError(name, f"cannot read as {fmt.upper()}: {_short(exc)}") from None
    if isinstance(scene, trimesh.Trimesh):
        return _Mesh(np.asarray(scene.vertices, dtype=np.float64), np.asarray(scene.faces, dtype=np.int64))
    part_of = _gltf_parts(header) if fmt in Y_UP_FORMATS else _frame_parts
    parents = scene.graph.transforms.parents
    geometry_order = {g: i for i, g in enumerate(scene.geometry)}
    items = []
    for node in scene.graph.nodes_geometry:
        transform, geom_name = scene.graph[node]
        part, order = part_of(node, parents)
        items.append((order, geometry_order.get(geom_name, 0), str(node), part, transform, geom_name))
    items.sort(key=lambda item: item[:3])
    verts, faces, labels, skipped = [], [], [], {}
    part_index: dict[str, int] = {}
    offset = 0
    for _, _, _, part, transform, geom_name in items:
        geom = scene.geometry[geom_name]
        if not isinstance(geom, trimesh.Trimesh):
            kind = {"Path3D": "line primitives", "Path2D": "line primitives",
                    "PointCloud": "point primitives"}.get(type(geom).__name__, f"{type(geom).__name__} primitives")
            skipped[kind] = skipped.get(kind, 0) + 1
            continue
        v = np.asarray(geom.vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(geom.faces, dtype=np.int64).reshape(-1, 3)
        if len(f) == 0:
            continue
        T = np.asarray(transform, dtype=np.float64)
        v = v @ T[:3, :3].T + T[:3, 3]
        if np.linalg.det(T[:3, :3]) < 0:  # a mirroring node turns the winding (glTF 2.0, 3.7.4)
            f = f[:, ::-1]
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
        labels.append(np.full(len(f), part_index.setdefault(part, len(part_index)) if part is not None else -1))
    if not verts:
        return _Mesh(np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), skipped)
    vertices, faces_all, labels_all = np.concatenate(verts), np.concatenate(faces), np.concatenate(labels)
    face_part, part_names = None, ()
    if part_index:
        face_part, part_names = _compact_parts(labels_all, list(part_index))
    return _Mesh(vertices, faces_all, skipped, face_part, part_names)


def _gltf_parts(header: dict | None):
    """part_of(frame, parents) -> (part name or None, sort key) for a trimesh scene read from a
    glTF: the glTF node carrying the mesh (trimesh puts a mesh's extra primitives on child
    frames of its node) named as in the file, in the file's node order. None when no node in
    the file has a name."""
    from trimesh.util import unique_name

    nodes = header.get("nodes") if header else None
    nodes = nodes if isinstance(nodes, list) else []
    frames: dict[str, int] = {}
    counts: dict = {}
    for i, n in enumerate(nodes):  # trimesh's own naming of the node frames
        n = n if isinstance(n, dict) else {}
        frames[unique_name(n.get("name", str(i)), frames, counts=counts)] = i
    named = any(isinstance(n, dict) and n.get("name") for n in nodes)

    def part_of(frame, parents):
        node, seen = frame, 0
        while node not in frames and node in parents and seen < 64:
            node, seen = parents[node], seen + 1
        if node not in frames:
            return (None, len(nodes))
        i = frames[node]
        if not named:
            return (None, i)
        n = nodes[i] if isinstance(nodes[i], dict) else {}
        return (str(n.get("name") or f"node {i}"), i)

    return part_of


def _frame_parts(frame, parents):
    """Collada (and any other scene): the frame's own name."""
    return (str(frame), 0)


_VOLUME_CELLS = ("tetra", "hexahedron", "wedge", "pyramid", "polyhedron")


def _cell_description(kind: str) -> str:
    if kind.startswith("line"):
        return "line cells"
    if kind == "vertex":
        return "vertex cells (points)"
    if kind.startswith(_VOLUME_CELLS):
        return f"{kind} cells (volume, not a surface)"
    return f"{kind} cells"


def _read_meshio(path: str, data: bytes, fmt: str, name: str) -> _Mesh:
    import tempfile

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
        raise InputError(name, f"cannot read as {fmt.upper()}: {_short(exc)}") from None
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
    return _Mesh(points, faces, skipped)


_MESHIO_NAMES = {"vtk": "vtk", "vtu": "vtu", "msh": "gmsh", "mesh": "medit", "xdmf": "xdmf", "xmf": "xdmf",
                 "med": "med", "inp": "abaqus", "dat": "tecplot", "tec": "tecplot", "ugrid": "ugrid", "su2": "su2",
                 "avs": "avsucd", "f3grid": "flac3d", "wkt": "wkt"}


def _short(exc: Exception) -> str:
    text = str(exc).strip().splitlines()
    msg = text[0] if text else type(exc).__name__
    return msg[:200]
