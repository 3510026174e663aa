"""A compiled parser for the common shape of a numeric CSV chunk, compiled ahead of time (Cython).

Exactly the value ``float(text)`` gives, by Clinger's fast path: a decimal
with at most 15 significant digits and a power of ten within 10^+-22 is one
correctly rounded multiplication or division of two exact doubles. Anything
else (more digits, large exponents, nan/inf, quotes, empty cells, a wrong cell
count) makes the whole chunk fall back to the general readers, which also
name the bad line and column.

``parse_table(buf, rows, width, pow10)`` (in ``_csv_kernels.pyx``): ``rows`` lines of
``width`` comma-separated decimals from ``buf`` (uint8 text) with ``pow10 = POW10``;
returns ((rows, width) float64 values, ok).

The trajectory reader's kernels (``io.trajectory.csv_input`` and ``io.trajectory.csv_rows`` document them):
``parse_rows`` (rows of a chunk of bytes: numbers, ISO times, the text column's spans),
``Interner`` (entity ids to codes in order of first appearance), ``entity_order`` (each entity's
time order) and ``carry`` (a value carried forward per entity).
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.io._csv_kernels import Interner, carry, entity_order, parse_rows, parse_table  # noqa: F401

POW10 = np.array([10.0 ** k for k in range(23)])
