"""ESRI ASCII grids (``.asc``): tankcd's own parser of the header and the posts.

``esri_ascii_posts`` gives the posts as a raster (what a DEM source serves, ``terrain.grid.
sources``); ``parse_esri_ascii`` the same posts as a mesh's vertices and triangles with the
grid's structure (what a terrain read as a mesh keeps). Posts sit at cell centres: a header's
``xllcorner`` is moved by half a cell. A malformed header, a value that is not a number, a
non-finite height or a grid of fewer than 2 x 2 posts is an InputError naming the line.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.post_grid import PostGrid, PostVertices, grid_faces

SUFFIXES = ("asc",)

_HEADER_KEYS = {"ncols", "nrows", "xllcorner", "yllcorner", "xllcenter", "yllcenter", "cellsize", "dx", "dy", "nodata_value"}


def parse_esri_ascii(data: bytes, name: str) -> tuple[np.ndarray, np.ndarray, PostVertices]:
    """Parse an ESRI ASCII grid into vertices (n, 3), triangles (m, 3) and the grid structure.

    Posts sit at cell centres; the vertices are the valid posts, the south row first. A quad of
    four valid posts gives two triangles; a quad with exactly three valid posts gives the one
    triangle they span; NODATA posts are left out of the mesh.
    """
    z, valid, (x0, y0), (dx, dy) = esri_ascii_posts(data, name)
    nrows, ncols = z.shape
    vertex = np.full((nrows, ncols), -1, dtype=np.int64)  # south row first, as the vertices
    vertex[valid] = np.arange(int(valid.sum()))
    yy, xx = np.nonzero(valid)
    vertices = np.column_stack([x0 + xx * dx, y0 + yy * dy, z[valid]])
    north = np.ascontiguousarray(vertex[::-1])
    faces = grid_faces(north)
    if len(faces) == 0:
        raise InputError(name, "no cell has three valid posts: nothing to triangulate")
    return vertices, faces, PostVertices(PostGrid.from_south_west(nrows, ncols, x0, y0, dx, dy), north)


def esri_ascii_posts(data: bytes, name: str) -> tuple[np.ndarray, np.ndarray, tuple, tuple]:
    """The posts of an ESRI ASCII grid as its header describes them: heights (rows, cols) float64
    in the order the vertices of ``parse_esri_ascii`` take (row 0 SOUTH), the valid mask, the
    world x, y of the south-west post and the spacing (dx, dy)."""
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
