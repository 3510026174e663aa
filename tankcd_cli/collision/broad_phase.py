"""The broad phase over many vehicles' motion: which pairs of rigid segments may touch.

A vehicle's motion is a sequence of rigid segments: a time span [t0, t1] (s) over which its parts
move rigidly, and a conservative world box [lo, hi] (m) that holds the vehicle throughout it
(``collision.obstacles``: its box at the segment's middle grown by half its motion bound). Two
segments can touch only if

- their owners (entities) differ: one vehicle's own segments never pair;
- their boxes overlap, closed (a shared face, edge or corner counts: shapes that touch must reach
  the narrow phase);
- their time spans overlap, closed (spans that meet at one instant count).

So a segment is a closed box in (x, y, z, t), and the candidate pairs are the pairs of boxes that
overlap on all four axes, with different owners. Every method returns the same array: (P, 2)
int64 segment indices, i < j in each row, each pair once, rows sorted lexicographically, so the
result is a function of the segments alone, never of the order they came in or of the method
(fcl#368: results that reorder between updates). Only the input floats themselves are compared,
never differences of them, so touching is decided exactly at any coordinates (UTM eastings and
northings included).

Methods:

- ``brute_force``: every pair tested, in blocks of rows: the oracle;
- ``sort_and_sweep``: segments sorted on one axis (x, y, z or t: by default the one whose
  projected intervals overlap least, counted exactly), each segment's partners on that axis the
  segments after it in that order that start at or before its end, tested on the other axes and
  the owners as they are met, in compiled code (``collision._broad_phase``);
- ``uniform_grid``: a grid over x, y and time with cells of the segments' typical size; each
  segment goes into the cells it covers, pairs come from shared cells, each reported by one cell
  alone (the one holding the lower corner of the two segments' intersection), so no
  deduplication pass is needed; segments covering more than ``max_cells`` cells are swept
  against the rest instead;
- ``candidate_pairs``: the entry point, which picks one (its docstring gives the rule and the
  measurements behind it).

Memory: brute force and the grid generate and test candidates in blocks of at most ``block``
(default ``BLOCK``), the grid builds its entries a slab of columns of cells at a time (about
``GRID_SLAB``), and the sweep tests each candidate as it meets it, so the working memory is a few
arrays of M (about 100-200 bytes a segment, the inputs' copies included) and the output, however
many segments overlap on the sweep axis or share a cell. No per-segment Python loop: every step
is a numpy operation over a block, or the compiled sweep.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.collision._broad_phase import sweep_keys

METHODS = ("auto", "sort_and_sweep", "uniform_grid", "brute_force")
AXES = ("x", "y", "z", "t")

BLOCK = 1 << 18
"""Candidate pairs generated and tested at a time (about 15 MB of working arrays)."""

GRID_SCALE = (3.0, 2.0)
"""The grid's cells against the segments' typical size: side over the median horizontal extent,
length over the median time span (``grid_cell_size``). On the benchmark's exercises
(benchmarks/results/broad_phase.md, "The grid's cells") the best size tried moves with the
exercise and the run (sides of 2-6, lengths of 1-2), and this one stays within 20 % of it on
each; one time cell (a grid over x, y alone) is 2-8x slower."""

MAX_CELLS = 64
"""A segment covering more grid cells than this is swept against the rest, not entered in the
grid (a long segment of a vehicle that stood still between two rows, an outlier in size)."""

BRUTE_FORCE_BELOW = 128
"""``candidate_pairs`` tests every pair below this many segments, where the other methods' fixed
costs (sorts, a few dozen numpy calls) exceed the M (M - 1) / 2 tests."""

SWEEP_CANDIDATES_PER_SEGMENT = 200.0
"""``candidate_pairs`` sweeps while the sweep tests at most this many candidates per segment (its
cost grows with them: about 3.4 ns each, compiled) and uses the grid above (whose cost grows with
its entries, two to four per segment, and the pairs sharing its cells: 0.6-1 us a segment)."""

GRID_SLAB = 1 << 17
"""Grid entries (segment, cell) built at a time: the grid is processed in slabs of columns of
cells holding about this many (about 15 MB of working arrays); slabs of 2**16 to 2**30 entries
ran within the noise of one another on the benchmark's exercises."""

ESTIMATE_SAMPLE = 2048
"""Segments ``candidate_pairs`` counts the sweep's candidates on (a uniform sample; all of them
below this): about 1 ms, against 0.3 ms per 1,000 segments for the fastest method."""

_EMPTY = np.empty((0, 2), dtype=np.int64)


def _segments(lo, hi, t0, t1, owner):
    """Coerce and check the inputs: (L (M, 4), H (M, 4), owner (M,) int64), the segments as closed
    boxes in (x, y, z, t). ValueError on wrong shapes, non-finite values, lo > hi or t0 > t1."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    if lo.size == 0 and lo.ndim == 1:
        lo = lo.reshape(0, 3)
    if hi.size == 0 and hi.ndim == 1:
        hi = hi.reshape(0, 3)
    if lo.ndim != 2 or lo.shape[1] != 3 or hi.shape != lo.shape:
        raise ValueError(f"lo and hi must both be (M, 3) boxes, got shapes {lo.shape} and {hi.shape}")
    m = len(lo)
    t0 = np.asarray(t0, dtype=np.float64).reshape(-1)
    t1 = np.asarray(t1, dtype=np.float64).reshape(-1)
    owner = np.asarray(owner).reshape(-1)
    for name, a in (("t0", t0), ("t1", t1), ("owner", owner)):
        if a.shape != (m,):
            raise ValueError(f"{name} must have one value per segment ({m}), got {a.shape[0]}")
    if m and owner.dtype.kind not in "iub":
        raise ValueError(f"owner must be integer entity codes, got dtype {owner.dtype}")
    L = np.empty((m, 4))
    H = np.empty((m, 4))
    L[:, :3], L[:, 3] = lo, t0
    H[:, :3], H[:, 3] = hi, t1
    bad = ~(np.isfinite(L).all(axis=1) & np.isfinite(H).all(axis=1))
    if bad.any():
        raise ValueError(f"segment {int(np.flatnonzero(bad)[0])} has a non-finite box or time (NaN or inf)")
    bad = (L > H).any(axis=1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"segment {k} is inverted: lo {L[k, :3].tolist()}, hi {H[k, :3].tolist()}, "
                         f"t0 {L[k, 3]!r}, t1 {H[k, 3]!r} (need lo <= hi and t0 <= t1)")
    return L, H, owner.astype(np.int64, copy=False)


def _check_block(block) -> int:
    block = int(block)
    if block < 1:
        raise ValueError(f"block must be at least 1, got {block}")
    return block


def _check_axis(axis) -> int:
    if isinstance(axis, str):
        if axis not in AXES:
            raise ValueError(f"unknown axis {axis!r}: use one of {', '.join(AXES)}")
        return AXES.index(axis)
    if not 0 <= int(axis) < 4:
        raise ValueError(f"axis must be 0-3 (x, y, z, t), got {axis}")
    return int(axis)


def _pairs(keys: list, m: int, presorted: bool = False) -> np.ndarray:
    """(P, 2) rows (i, j) from pair keys i * m + j (i < j), sorted lexicographically."""
    keys = [k for k in keys if len(k)]
    if not keys:
        return _EMPTY.copy()
    k = np.concatenate(keys) if len(keys) > 1 else keys[0]
    if not presorted:
        k = np.sort(k)
    out = np.empty((len(k), 2), dtype=np.int64)
    np.floor_divide(k, m, out=out[:, 0])
    np.subtract(k, out[:, 0] * m, out=out[:, 1])
    return out


def _key(i, j, m):
    """The pair key of segments i and j (either order): min * m + max."""
    return np.minimum(i, j) * m + np.maximum(i, j)


def _ranges(first, count: np.ndarray, block: int):
    """Every (row, first[row] + k) with 0 <= k < count[row], in row order, as blocks of arrays
    (rows, partners) of at most ``block`` entries; a row longer than a block spans several.
    ``first`` None means row + 1 (a row's partners are the rows after it)."""
    end = np.cumsum(count)
    total = int(end[-1]) if len(end) else 0
    for k0 in range(0, total, block):
        k1 = min(k0 + block, total)
        r0 = int(np.searchsorted(end, k0, side="right"))           # the row holding entry k0
        r1 = int(np.searchsorted(end, k1 - 1, side="right")) + 1   # past the row holding k1 - 1
        start = end[r0:r1] - count[r0:r1]
        n = np.minimum(end[r0:r1], k1) - np.maximum(start, k0)
        rows = np.repeat(np.arange(r0, r1), n)
        k = np.arange(k0, k1) - np.repeat(start, n)
        yield rows, (k + rows + 1 if first is None else k + first[rows])


def _overlap(L_a, H_a, L_b, H_b, p, q, axes):
    """(K,) bool: entries p of set a and q of set b overlap (closed) on every axis of ``axes``;
    L_x, H_x are per-axis column lists of the two sets."""
    ok = None
    for a in axes:
        got = L_a[a][p] <= H_b[a][q]
        got &= L_b[a][q] <= H_a[a][p]
        ok = got if ok is None else ok & got
    return ok


# --- the oracle -------------------------------------------------------------------------------

def brute_force(lo, hi, t0, t1, owner, *, block: int = BLOCK) -> np.ndarray:
    """Every pair of M segments tested: the oracle the other methods are checked against.

    lo, hi : (M, 3) float, m; t0, t1 : (M,) float, s; owner : (M,) int
    Returns (P, 2) int64 candidate pairs (see the module's docstring). M (M - 1) / 2 tests, in
    blocks of rows of about ``block`` pairs each.
    """
    L, H, own = _segments(lo, hi, t0, t1, owner)
    return _brute_force(L, H, own, _check_block(block))


def _brute_force(L, H, own, block):
    m = len(L)
    cols_L = [np.ascontiguousarray(L[:, a]) for a in range(4)]
    cols_H = [np.ascontiguousarray(H[:, a]) for a in range(4)]
    keys = []
    a = 0
    while a < m - 1:
        b = min(m - 1, a + max(1, block // (m - a - 1)))   # rows a .. b - 1 against columns a + 1 ..
        ok = np.arange(a + 1, m)[None, :] > np.arange(a, b)[:, None]
        ok &= own[a:b, None] != own[None, a + 1:]
        for axis in range(4):
            ok &= cols_L[axis][a:b, None] <= cols_H[axis][None, a + 1:]
            ok &= cols_L[axis][None, a + 1:] <= cols_H[axis][a:b, None]
        r, c = np.nonzero(ok)                    # row-major: already in lexicographic order
        keys.append((r + a) * m + (c + a + 1))
        a = b
    return _pairs(keys, m, presorted=True)


# --- sort and sweep ---------------------------------------------------------------------------

def projected_overlaps(lo, hi, t0, t1) -> np.ndarray:
    """(4,) int64: per axis x, y, z, t, the number of pairs of segments whose intervals on that
    axis overlap (closed), owners aside: the candidates a sweep on that axis tests. One sort per
    axis."""
    m = len(np.asarray(t0).reshape(-1))
    L, H, _ = _segments(lo, hi, t0, t1, np.zeros(m, dtype=np.int64))
    return _projected_overlaps(L, H)


def _projected_overlaps(L, H) -> np.ndarray:
    m = len(L)
    out = np.zeros(4, dtype=np.int64)
    for axis in range(4):
        starts = np.sort(L[:, axis])
        # in the order of the starts, segment p's partners are those after it starting at or before
        # its end: (the count starting at or before its end) - (p + 1); summed over p
        out[axis] = int(np.searchsorted(starts, H[:, axis], side="right").sum()) - m * (m + 1) // 2
    return out


def _estimated_overlaps(L, H, sample: int = ESTIMATE_SAMPLE) -> np.ndarray:
    """``_projected_overlaps`` exactly up to ``sample`` segments; above, on a uniform sample of
    that many (a fixed seed: the same estimate every time) scaled by M (M - 1) / (s (s - 1)), the
    inverse of the chance that both segments of a pair are in the sample."""
    m = len(L)
    if m <= sample:
        return _projected_overlaps(L, H).astype(np.float64)
    pick = np.sort(np.random.default_rng(0).choice(m, sample, replace=False))
    return _projected_overlaps(L[pick], H[pick]).astype(np.float64) * (m * (m - 1.0) / (sample * (sample - 1.0)))


def sort_and_sweep(lo, hi, t0, t1, owner, *, axis: int | str | None = None, block: int = BLOCK) -> np.ndarray:
    """Candidate pairs by sorting the segments on one axis and sweeping.

    lo, hi : (M, 3) float, m; t0, t1 : (M,) float, s; owner : (M,) int
    axis : 0-3 or "x", "y", "z", "t"; by default the axis with the fewest projected overlaps
        (``projected_overlaps``: exactly the candidates the sweep then tests)
    Returns (P, 2) int64 candidate pairs (see the module's docstring).

    In the order of the segments' starts on the axis, segment p's partners on that axis are
    exactly the segments q > p starting at or before p's end (ties in start in either order:
    the one sorting first finds the other). Each overlapping pair is met once, from the one
    sorting first, and tested on the other axes and the owners as it is met, in compiled code: no
    candidate arrays are formed, so ``block`` (checked, for the other methods' sake) bounds
    nothing here.
    """
    L, H, own = _segments(lo, hi, t0, t1, owner)
    block = _check_block(block)
    if len(L) < 2:
        return _EMPTY.copy()
    counts = _projected_overlaps(L, H)
    axis = int(np.argmin(counts)) if axis is None else _check_axis(axis)
    return _pairs(_sweep(L, H, own, np.arange(len(L)), axis, _others(axis, counts), block), len(L))


def _others(axis, counts):
    """The axes other than ``axis``, the most selective (fewest projected overlaps) first: the
    candidates it rejects are dropped before the rest are read."""
    return sorted((a for a in range(4) if a != axis), key=lambda a: counts[a])


def _sweep(L, H, own, ids, axis, others, block) -> list:
    """Pair keys of the segments ``ids`` among themselves, swept on ``axis``: the compiled sweep
    (``collision._broad_phase.sweep_keys``), each candidate tested as it is met, so its memory is
    the output's (``block`` bounds the numpy methods' candidate arrays; none are formed here)."""
    order = ids[np.argsort(L[ids, axis], kind="stable")].astype(np.int64, copy=False)
    return [sweep_keys(np.ascontiguousarray(L), np.ascontiguousarray(H), np.ascontiguousarray(own, dtype=np.int64),
                       order, int(axis), np.asarray(others, dtype=np.int64))]


def _sweep_between(L, H, own, ids_a, ids_b, axis, others, block) -> list:
    """Pair keys of each segment of ``ids_a`` with each of ``ids_b`` (two disjoint sets), swept on
    ``axis``: a pair overlaps on the axis exactly when b starts within a (start_a <= start_b <=
    end_a) or a starts within b after b's start (start_b < start_a <= end_b), two range queries,
    one from each side, that never both hold."""
    m = len(L)
    keys = []
    sides = []
    for ids in (ids_a, ids_b):
        order = ids[np.argsort(L[ids, axis], kind="stable")]
        sides.append((order, [np.ascontiguousarray(L[order, a]) for a in range(4)],
                      [np.ascontiguousarray(H[order, a]) for a in range(4)], own[order]))
    for (o_r, L_r, H_r, own_r), (o_s, L_s, H_s, own_s), side in ((sides[0], sides[1], "left"),
                                                                 (sides[1], sides[0], "right")):
        # rows r, partners s: the s starting within r's interval (for b within a from the left,
        # equal starts included; for a within b strictly after b's start)
        first = np.searchsorted(L_s[axis], L_r[axis], side=side)
        count = np.searchsorted(L_s[axis], H_r[axis], side="right") - first
        for p, q in _ranges(first, count, block):
            ok = own_r[p] != own_s[q]
            ok &= _overlap(L_r, H_r, L_s, H_s, p, q, others)
            keys.append(_key(o_r[p[ok]], o_s[q[ok]], m))
    return keys


# --- the uniform grid -------------------------------------------------------------------------

def grid_cell_size(lo, hi, t0=None, t1=None, scale: tuple[float, float] = GRID_SCALE) -> tuple[float, float]:
    """The grid's cells: (side in x and y, m; length in time, s).

    lo, hi : (M, 3) float, m; t0, t1 : (M,) float, s
    The side is ``scale[0]`` times the median over the segments of their larger horizontal
    extent, the length ``scale[1]`` times the median time span (a typical segment then covers
    one or two cells per axis); each at least 2**-20 of the segments' spread on its axes (so
    cell indices stay small), and 1 where every segment is a point or an instant. Without t0, t1
    the length is inf: one time cell, a grid over x, y alone."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    if len(lo) == 0:
        return 1.0, (1.0 if t0 is not None else float("inf"))

    def rule(factor, extent, spread):
        cell = max(factor * float(np.median(extent)), spread * 2.0**-20)
        return cell if cell > 0 else 1.0

    side = rule(scale[0], (hi[:, :2] - lo[:, :2]).max(axis=1),
                float((hi[:, :2].max(axis=0) - lo[:, :2].min(axis=0)).max()))
    if t0 is None:
        return side, float("inf")
    t0, t1 = np.asarray(t0, dtype=np.float64), np.asarray(t1, dtype=np.float64)
    return side, rule(scale[1], t1 - t0, float(t1.max() - t0.min()))


def uniform_grid(lo, hi, t0, t1, owner, *, cell: float | None = None, time_cell: float | None = None,
                 block: int = BLOCK, max_cells: int = MAX_CELLS, slab: int = GRID_SLAB) -> np.ndarray:
    """Candidate pairs through a uniform grid over x, y and time.

    lo, hi : (M, 3) float, m; t0, t1 : (M,) float, s; owner : (M,) int
    cell : the cells' side in x and y, m; time_cell : their length in time, s (inf: one time
        cell, a grid over x, y alone); by default ``grid_cell_size``'s
    max_cells : a segment covering more cells than this is swept against the others instead
    slab : about how many (segment, cell) entries are built at a time (columns of cells at a time)
    Returns (P, 2) int64 candidate pairs (see the module's docstring).

    Time is a dimension of the grid because one place holds many segments at different times (a
    vehicle's own segments, the column behind it): on the benchmark's exercises it cuts the
    candidates ten to twenty times. A cell index is floor((v - v_min) / size), nondecreasing in
    v, so two segments whose closed intervals overlap have overlapping ranges of cells: they
    share a cell, touching ones included. Of the cells two segments share, the pair is kept in
    the one holding the lower corner of their intersection (on each axis the larger of the two
    segments' lowest cells), so each pair is reported once with no deduplication pass.
    Segments covering more than ``max_cells`` cells are swept against the grid's segments and
    among themselves (``sort_and_sweep``'s method), on the axis where they overlap fewest.
    """
    L, H, own = _segments(lo, hi, t0, t1, owner)
    block = _check_block(block)
    if len(L) < 2:
        return _EMPTY.copy()
    if cell is None or time_cell is None:
        side, length = grid_cell_size(L[:, :3], H[:, :3], L[:, 3], H[:, 3])
        cell = side if cell is None else cell
        time_cell = length if time_cell is None else time_cell
    return _pairs(_grid(L, H, own, float(cell), float(time_cell), block, int(max_cells), _check_block(slab)), len(L))


def _grid(L, H, own, cell, time_cell, block, max_cells, slab=GRID_SLAB) -> list:
    m = len(L)
    sizes = np.array([cell, cell, time_cell])
    if not (sizes > 0).all():          # NaN fails too
        raise ValueError(f"cell and time_cell must be positive, got {cell!r} and {time_cell!r}")
    dims = [0, 1, 3]
    origin = L[:, dims].min(axis=0)
    # cell indices in 32 bits (grid_cell_size's cells make at most 2**20 + 1 an axis), keys in 64
    top = np.floor((H[:, dims].max(axis=0) - origin) / sizes)
    if (top >= 2**30).any() or float(np.prod(top + 1)) >= 2.0**62:
        raise ValueError(f"cells of {cell!r} m and {time_cell!r} s are too small for the segments' spread")
    c_lo = np.floor((L[:, dims] - origin) / sizes).astype(np.int32)
    c_hi = np.floor((H[:, dims] - origin) / sizes).astype(np.int32)
    extent = top.astype(np.int64) + 1
    c_hi -= c_lo
    span = c_hi
    span += 1
    del c_hi
    large = span.prod(axis=1, dtype=np.int64) > max_cells
    # a cell's key: its three indices in mixed radix over the grid's extent
    stride = np.array([extent[1] * extent[2], extent[2], 1], dtype=np.int64)
    keys = []

    # slabs of whole columns of cells (one x index each) holding about ``slab`` entries each, so
    # the entries' memory stays bounded; a cell lies in one slab, so a pair's cell of record too
    small = np.flatnonzero(~large)
    small = small[np.argsort(c_lo[small, 0], kind="stable")]
    per_column = span[small, 1] * span[small, 2]            # entries a segment puts in each column
    column = np.zeros(extent[0] + 1, dtype=np.int64)
    np.add.at(column, c_lo[small, 0], per_column)
    np.add.at(column, c_lo[small, 0] + span[small, 0], -per_column)
    entries = np.cumsum(np.cumsum(column)[:-1])             # entries in columns 0 .. x, cumulated
    cuts = np.unique(np.searchsorted(entries, np.arange(slab, int(entries[-1]) if len(entries) else 0, slab)))
    bounds = np.r_[0, cuts + 1, extent[0]] if len(cuts) else np.array([0, extent[0]])
    bounds = np.unique(np.minimum(bounds, extent[0]))
    starts_x = c_lo[small, 0]
    for x0, x1 in zip(bounds[:-1], bounds[1:]):
        # the segments covering columns x0 .. x1 - 1: a small one starts at most max_cells - 1
        # columns before x0
        a = np.searchsorted(starts_x, x0 - max_cells, side="left")
        b = np.searchsorted(starts_x, x1, side="left")
        ids = small[a:b]
        ids = ids[c_lo[ids, 0] + span[ids, 0] > x0]
        if len(ids) > 1:
            keys += _grid_slab(L, H, own, ids, c_lo, span, stride, x0, x1, block, m)

    big = np.flatnonzero(large)
    if len(big):
        counts = _estimated_overlaps(L[big], H[big])
        axis = int(np.argmin(counts))
        others = _others(axis, counts)
        keys += _sweep(L, H, own, big, axis, others, block)
        keys += _sweep_between(L, H, own, big, np.flatnonzero(~large), axis, others, block)
    return keys


def _grid_slab(L, H, own, ids, c_lo, span, stride, x0, x1, block, m) -> list:
    """Pair keys from the cells of columns x0 .. x1 - 1 that segments ``ids`` cover."""
    keys = []
    first_x = np.maximum(c_lo[ids, 0], x0).astype(np.int64)
    width = np.minimum(c_lo[ids, 0] + span[ids, 0], x1) - first_x
    n = width * span[ids, 1] * span[ids, 2]
    # the slab's entries: (cell key, segment) for every cell of the slab a segment covers,
    # sorted by cell
    seg = np.repeat(ids, n)
    rest = np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n)
    key = np.zeros(len(seg), dtype=np.int64)
    for d, low, w in ((2, c_lo[seg, 2], span[seg, 2]), (1, c_lo[seg, 1], span[seg, 1]),
                      (0, np.repeat(first_x, n), np.repeat(width, n))):
        key += (low + rest % w) * stride[d]          # int64: rest is
        rest //= w
    del rest, low, w
    order = np.argsort(key, kind="stable")
    key, seg = key[order], seg[order]
    del order
    # each entry's partners: the entries after it in its cell
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    length = np.diff(np.r_[start, len(key)])
    count = np.repeat(start + length, length) - np.arange(1, len(key) + 1)
    del start, length
    # the entries' own copies of what the test reads: a candidate's two entries lie in one cell,
    # next to each other, so its reads stay local
    e_own = own[seg]
    eL = [L[seg, a] for a in range(4)]
    eH = [H[seg, a] for a in range(4)]
    for p, q in _ranges(None, count, block):
        ok = e_own[p] != e_own[q]
        ok &= _overlap(eL, eH, eL, eH, p, q, (0, 1, 3, 2))
        p, q = p[ok], q[ok]
        i, j = seg[p], seg[q]
        # the pair's cell of record: the one holding its intersection's lower corner
        ref = np.maximum(c_lo[i, 0], c_lo[j, 0]) * stride[0]    # int64: stride is
        ref += np.maximum(c_lo[i, 1], c_lo[j, 1]) * stride[1]
        ref += np.maximum(c_lo[i, 2], c_lo[j, 2])
        here = ref == key[p]
        keys.append(_key(i[here], j[here], m))
    return keys


# --- the entry point --------------------------------------------------------------------------

def candidate_pairs(lo, hi, t0, t1, owner, *, method: str = "auto", block: int = BLOCK) -> np.ndarray:
    """The pairs of segments that may touch: closed boxes and closed time spans overlapping,
    owners different.

    lo, hi : (M, 3) float, world boxes, m; t0, t1 : (M,) float, time spans, s (t0 <= t1)
    owner : (M,) int, entity codes (segments of one owner never pair)
    method : "auto", "sort_and_sweep", "uniform_grid" or "brute_force"
    Returns (P, 2) int64 segment indices, i < j, each pair once, sorted lexicographically; the
    same array whichever method runs.

    ``auto``, from benchmarks/results/broad_phase.md (vehicles driving for 10 s at 10 Hz, spread
    over 10 km x 10 km or crowded in platoons in 1 km x 1 km; every method in the same run):

    - fewer than ``BRUTE_FORCE_BELOW`` (128) segments: brute force. It was the fastest up to 50
      segments against the numpy sweep; against the compiled one it is within 0.05 ms of it
      there (0.03-0.08 ms against 0.03 ms at 20-100 segments) and from 160 on 3.5x slower or
      more (at 1,000 segments 23x).
    - otherwise the sweep's candidates K on its best axis are counted (exactly up to 2,048
      segments, else estimated on a fixed uniform sample of 2,048: within 3 % on the benchmark)
      and the sweep runs while K <= ``SWEEP_CANDIDATES_PER_SEGMENT`` (200) per segment, the grid
      above. The compiled sweep's time follows K (about 3.4 ns a candidate), the grid's its
      entries and the pairs sharing its cells (0.6-1 us a segment). On the benchmark: 100,000
      segments spread, K = 94, the sweep 0.042 s against the grid's 0.062 s; 10,000 in
      platoons, K = 149, 0.0038 s against 0.0055 s; 100,000 in platoons, K = 826, 0.28 s
      against 0.11 s (the grid's). The segments of a 2 Hz exercise's time window (10,000 of
      1,000 T-72s over 4 km, K = 57) take 3.6 ms swept, 8-15 ms in the grid.
    """
    if method not in METHODS:
        raise ValueError(f"unknown broad-phase method {method!r}: use one of {', '.join(METHODS)}")
    L, H, own = _segments(lo, hi, t0, t1, owner)
    block = _check_block(block)
    m = len(L)
    if m < 2:
        return _EMPTY.copy()
    counts = None
    if method == "auto":
        method, counts = _choose(L, H)
    if method == "brute_force":
        return _brute_force(L, H, own, block)
    if method == "uniform_grid":
        side, length = grid_cell_size(L[:, :3], H[:, :3], L[:, 3], H[:, 3])
        return _pairs(_grid(L, H, own, side, length, block, MAX_CELLS), m)
    counts = _projected_overlaps(L, H) if counts is None else counts
    axis = int(np.argmin(counts))
    return _pairs(_sweep(L, H, own, np.arange(m), axis, _others(axis, counts), block), m)


def chosen_method(lo, hi, t0, t1) -> str:
    """The method ``candidate_pairs(method="auto")`` runs on these segments (owners aside)."""
    m = len(np.asarray(t0).reshape(-1))
    L, H, _ = _segments(lo, hi, t0, t1, np.zeros(m, dtype=np.int64))
    return _choose(L, H)[0]


def _choose(L, H):
    """``auto``'s rule: (method, the sweep's estimated candidates per axis or None)."""
    m = len(L)
    if m < BRUTE_FORCE_BELOW:
        return "brute_force", None
    counts = _estimated_overlaps(L, H)
    return ("uniform_grid" if counts.min() > SWEEP_CANDIDATES_PER_SEGMENT * m else "sort_and_sweep"), counts
