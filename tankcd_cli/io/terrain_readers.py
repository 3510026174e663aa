"""Terrain readers: a registry keyed by file suffix, returning plain arrays.

Every reader returns a :class:`RawTerrain` in the world frame (x east, y north,
z up, metres, float64). Mesh formats go through trimesh (OBJ, PLY, STL, OFF,
GLB/GLTF) or straight through meshio (VTK, VTU, Gmsh, XDMF, ...), as trimesh
itself recommends for meshio's formats; ESRI ASCII grids have their own reader
that keeps the grid structure for O(1) height queries later on.
"""

from __future__ import annotations

import hashlib
import math
import io
import os
from dataclasses import dataclass

import numpy as np

from tankcd_cli.errors import InputError

TRIMESH_SUFFIXES = ("obj", "ply", "stl", "off", "glb", "gltf")
MESHIO_SUFFIXES = ("vtk", "vtu", "msh", "mesh", "xdmf", "xmf", "med", "inp", "dat", "tec", "ugrid", "su2", "avs", "f3grid", "wkt")
GRID_SUFFIXES = ("asc",)


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
    """A terrain as read: vertices (n, 3) float64 m, faces (m, 3) int64, optional grid."""

    vertices: np.ndarray
    faces: np.ndarray
    grid: Grid | None
    source: str
    sha256: str
    format: str
    up: str = "z"


def known_formats() -> tuple[str, ...]:
    return GRID_SUFFIXES + TRIMESH_SUFFIXES + MESHIO_SUFFIXES


def read_terrain(path: str, up: str = "z", fmt: str | None = None) -> RawTerrain:
    """Read a terrain mesh or DEM.

    path : file path, or "-" for standard input (then ``fmt`` is required)
    up : "z" (default) or "y"; a y-up mesh is turned +90 deg about x into z-up
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
    if fmt not in known_formats():
        raise InputError(name, f"unknown terrain format {fmt!r}; known: {', '.join(known_formats())}, h5 (a store)")
    data = _read_bytes(path, name)
    if not data.strip():
        raise InputError(name, "file is empty")
    digest = hashlib.sha256(data).hexdigest()
    if fmt in GRID_SUFFIXES:
        vertices, faces, grid = parse_esri_ascii(data, name)
    elif fmt in TRIMESH_SUFFIXES:
        vertices, faces = _read_trimesh(data, fmt, name)
        grid = None
    else:
        vertices, faces = _read_meshio(path, data, fmt, name)
        grid = None
    if up not in ("z", "y"):
        raise InputError(name, f"unknown up axis {up!r}; use z or y")
    if up == "y":
        if grid is not None:
            raise InputError(name, "--up y makes no sense for a DEM grid (grids are z-up)")
        vertices = np.column_stack([vertices[:, 0], -vertices[:, 2], vertices[:, 1]])
    _check_arrays(vertices, faces, name)
    return RawTerrain(vertices, faces, grid, name, digest, fmt, up)


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

def read_simple_obj(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and triangles of a plain OBJ (``v x y z`` and triangular ``f a b c``, indices
    with or without ``/vt/vn``), or None when the file needs a full reader (polygons, negative
    indices, unparseable lines). Saves importing trimesh (most of a second) for the common case.
    """
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return None
    lines = text.splitlines()
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
        if len(f_tokens) != 3 * len(f_lines):  # polygons
            return None
        if "/" in f_lines[0] or any("/" in t for t in f_tokens[:3]):
            f_tokens = [t.split("/", 1)[0] for t in f_tokens]
        faces = np.array(f_tokens, dtype=np.int64).reshape(-1, 3)
    except (ValueError, OverflowError):
        return None
    if (faces <= 0).any():  # relative (negative) indices: the full reader resolves them
        return None
    return vertices, faces - 1


def _check_obj_lines(data: bytes, name: str) -> None:
    """Reject the vertex and face lines a full reader would skip or misread (it drops short faces silently)."""
    text = data.decode("utf-8", errors="replace")
    for number, line in enumerate(text.splitlines(), start=1):
        tokens = line.split()
        if not tokens or tokens[0] not in ("v", "f"):
            continue
        if tokens[0] == "v":
            try:
                xyz = [float(t) for t in tokens[1:4]]
            except ValueError:
                xyz = []
            if len(xyz) < 3 or not all(math.isfinite(c) for c in xyz):
                raise InputError(name, f"a vertex needs three finite numbers: {line.strip()[:60]!r}", where=f"line {number}")
        else:
            ok = len(tokens) >= 4
            for t in tokens[1:]:
                head = t.split("/", 1)[0]
                ok = ok and head.lstrip("-").isdigit() and 0 < abs(int(head)) < 2**31
            if not ok:
                raise InputError(name, f"a face needs three or more vertex indices (from 1, or negative): "
                                       f"{line.strip()[:60]!r}", where=f"line {number}")


def _read_trimesh(data: bytes, fmt: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    if fmt == "obj":
        if data.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark would hide the first line's keyword
            data = data[3:]
        simple = read_simple_obj(data)
        if simple is not None:
            return simple
        _check_obj_lines(data, name)
    import trimesh

    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=fmt, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed input
        raise InputError(name, f"cannot read as {fmt.upper()}: {_short(exc)}") from None
    vertices = np.asarray(getattr(loaded, "vertices", np.empty((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.empty((0, 3))), dtype=np.int64)
    return vertices.reshape(-1, 3), faces.reshape(-1, 3)


def _read_meshio(path: str, data: bytes, fmt: str, name: str) -> tuple[np.ndarray, np.ndarray]:
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
    for block in mesh.cells:
        cells = np.asarray(block.data, dtype=np.int64)
        if block.type == "triangle":
            tris.append(cells)
        elif block.type == "quad":
            tris += [cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]]
    faces = np.concatenate(tris) if tris else np.empty((0, 3), dtype=np.int64)
    return points, faces


_MESHIO_NAMES = {"vtk": "vtk", "vtu": "vtu", "msh": "gmsh", "mesh": "medit", "xdmf": "xdmf", "xmf": "xdmf",
                 "med": "med", "inp": "abaqus", "dat": "tecplot", "tec": "tecplot", "ugrid": "ugrid", "su2": "su2",
                 "avs": "avsucd", "f3grid": "flac3d", "wkt": "wkt"}


def _short(exc: Exception) -> str:
    text = str(exc).strip().splitlines()
    msg = text[0] if text else type(exc).__name__
    return msg[:200]
