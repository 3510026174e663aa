"""A compiled reader for the plain shape of an OBJ file, compiled ahead of time (Cython).

It takes exactly the files the Python fast path ``terrain_readers._simple_obj`` takes
(or fewer) and gives the same vertices, faces, skipped counts and parts, bit for bit,
without a Python object per line: one counting pass and one filling pass over the bytes,
without the GIL.

The plain shape, line by line (LF or CRLF ends): ``v x y z`` (exactly three decimals),
``f a b c`` (exactly three indices ``i``, ``i/j``, ``i//k`` or ``i/j/k``, ``i`` from 1 to the
vertex count; slashes only when the first face line has them, as ``_simple_obj`` reads
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

``scan_obj(data, pow10)`` (in ``_obj.pyx``) with ``pow10 = _POW10``: None, or (vertices
(n, 3) float64, faces (m, 3) int64 zero-based, n_lines, n_points, mark_kind (k,) uint8
(``ord("o")``/``ord("g")``), mark_faces (k,) int64 faces before each mark, mark_start,
mark_end (k,) int64 the byte range of each mark's name after "o "/"g ", to be decoded and
stripped by the caller).
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.io._obj import scan_obj  # noqa: F401

_POW10 = np.array([10.0 ** k for k in range(23)])
