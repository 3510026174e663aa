"""OBJ files: three readers, cheapest first, that give the same mesh where they take a file.

``compiled_obj`` scans the plain shape of an OBJ in compiled code (``_obj.pyx``, below);
``simple_obj`` reads the same shape in Python; ``parse_obj`` reads any OBJ line by line.
``read_obj`` takes the first that does not decline the file. Polygons are split into fans from
their first vertex (as trimesh splits them); the ``o`` objects, else the ``g`` groups, are the
parts; faces of fewer than three vertices, ``l`` and ``p`` elements are left out and counted.

The compiled scanner (Cython, compiled ahead of time) takes exactly the files ``simple_obj``
takes (or fewer) and gives the same vertices, faces, skipped counts and parts, bit for bit,
without a Python object per line: one counting pass and one filling pass over the bytes,
without the GIL.

The plain shape, line by line (LF or CRLF ends): ``v x y z`` (exactly three decimals),
``f a b c`` (exactly three indices ``i``, ``i/j``, ``i//k`` or ``i/j/k``, ``i`` from 1 to the
vertex count; slashes only when the first face line has them, as ``simple_obj`` reads
them), ``l ...`` and ``p ...`` (counted), ``o NAME`` and ``g NAME`` (marked with the number
of faces before them), ``vt``/``vn``/``vp``, ``#``, ``s ``, ``usemtl``, ``mtllib`` lines and
blank lines (ignored). Numbers are exactly what ``float(text)`` gives, by Clinger's fast
path as in ``csv_kernels``: at most 15 significant digits and a power of ten within
10^+-22. Anything else declines the WHOLE file (None) and the Python readers decide:
a fourth vertex number, polygons or short faces, zero or negative indices, an index past
the last vertex, 16 or more significant digits, nan/inf, tabs or blanks before a keyword,
a bare ``g``, a line ending in a backslash (continuation), an unknown keyword, a text that
is not UTF-8 or holds a line break other than LF/CRLF (a lone CR, VT, FF, U+0085,
U+2028 ...), a non-ASCII byte anywhere but in a comment, a name or an ignored line.

``scan_obj(data, pow10)`` (in ``_obj.pyx``) with ``pow10 = POW10``: None, or (vertices
(n, 3) float64, faces (m, 3) int64 zero-based, n_lines, n_points, mark_kind (k,) uint8
(``ord("o")``/``ord("g")``), mark_faces (k,) int64 faces before each mark, mark_start,
mark_end (k,) int64 the byte range of each mark's name after "o "/"g ", to be decoded and
stripped by the caller).
"""

from __future__ import annotations

import math
import re

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io._obj import scan_obj
from tankcd_cli.io.file_mesh import DEFAULT_PART, FileMesh, compact_parts

POW10 = np.array([10.0 ** k for k in range(23)])  # the scanner's powers of ten (Clinger's fast path)

SHORT_FACES = "faces with fewer than 3 vertices"
OBJ_LINES = "line elements"
OBJ_POINTS = "point elements"

_OBJ_KNOWN_PREFIXES = ("v ", "f ", "vt", "vn", "vp", "#", "s ", "usemtl", "mtllib", "l ", "p ", "o ", "g ")


def read_simple_obj(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and triangles of a plain OBJ (``v x y z`` and triangular ``f a b c``, indices
    with or without ``/vt/vn``), or None when the file needs a full reader (polygons, short
    faces, negative indices, unparseable or unusual lines). Saves importing anything (and a
    Python loop over the lines) for the common case. ``l`` and ``p`` elements and ``o``/``g``
    parts are left out here; ``simple_obj`` counts and keeps them.
    """
    simple = simple_obj(data)
    return None if simple is None else (simple.vertices, simple.faces)


def simple_obj(data: bytes) -> FileMesh | None:
    """The Python fast reader: ``read_simple_obj``'s files, with their skipped counts and parts."""
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
    return FileMesh(vertices, faces - 1, skipped, face_part, part_names)


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
            return compact_parts(labels, list(ids))
    return None, ()


def read_obj(data: bytes, name: str) -> FileMesh:
    """An OBJ: the compiled reader, else the Python fast reader, when they suffice; the full one otherwise."""
    if data.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark would hide the first line's keyword
        data = data[3:]
    simple = compiled_obj(data)
    if simple is None:
        simple = simple_obj(data)
    return simple if simple is not None else parse_obj(data, name)


def compiled_obj(data: bytes) -> FileMesh | None:
    """What ``simple_obj`` gives, read by the compiled scanner (``scan_obj``), or None when
    it declines the file (then ``simple_obj`` and ``parse_obj`` decide, as without it; a face
    index past the last vertex is declined too, and refused as before by ``_check_arrays``)."""
    scanned = scan_obj(data, POW10)
    if scanned is None:
        return None
    vertices, faces, n_lines, n_points, mark_kind, mark_faces, mark_start, mark_end = scanned
    skipped = {}
    if n_lines:
        skipped[OBJ_LINES] = n_lines
    if n_points:
        skipped[OBJ_POINTS] = n_points
    face_part, part_names = _marked_obj_parts(data, mark_kind, mark_faces, mark_start, mark_end, len(faces))
    return FileMesh(vertices, faces, skipped, face_part, part_names)


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
            return compact_parts(labels, list(ids))
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


def parse_obj(data: bytes, name: str) -> FileMesh:
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
            face_part, part_names = compact_parts(np.array(labels, dtype=np.int64), list(names))
            break
    return FileMesh(vertices, faces, skipped, face_part, part_names)
