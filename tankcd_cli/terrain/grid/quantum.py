"""Quantized heights: finding a DEM's height step, and the filter that keeps the classes from
following its terraces.

A DEM whose heights take only the levels offset + k q (integer DEMs, 8- and 16-bit heightmaps,
terraced exports) is ground rounded to the step q: the curvature at the post spacing h then
sees the terraces, each edge a kink of q / h^2 (an 8-bit heightmap, q = 0.157 m at 2 m posts:
0.04 1/m, twice the uneven threshold), and the classes draw contour lines.

**Detection** (``find_quantum``), cheap: at most ``SAMPLE_WINDOWS`` windows of
``SAMPLE_SIDE`` x ``SAMPLE_SIDE`` posts spread over the DEM, never the whole raster. The
sampled heights are quantized when every gap between their distinct values is a whole multiple
of one step (the smallest gap, or its half, third, ..., eighth, fitted to all the gaps by least
squares), to a tolerance of a few units in the last place of the heights' number type, the
step being larger than 64 of those units (a float32 raster's own lattice is no quantum), and
when the step shows: a quadratic fitted to each window leaves residuals of at least a tenth of
the step in rms (ground that is exactly a plane or a quadratic, whose posts may fall on a
lattice, is not terraced). The rounding shows in the curvature when it, not the ground, makes
the relief at the post scale: the median |4-neighbour Laplacian| of the sampled heights is at
most 3 steps (``RELIEF_SHOWS``; rounding alone gives about 1, treads less). Rough ground
rounded finely (a survey to the millimetre, 1.6 cm steps under 5 cm of roughness: 11 steps) is
left as it is: there the rounding is noise the footprint averages take, and filtering it
would smooth the ground's own relief.

**The filter** (``smooth_within_quantum``): the true ground lies within half a step of each
quantized post, and the smoothest surface in that band has no terraces. ``passes`` times, every
post whose eight neighbours have heights is replaced by the 3 x 3 binomial average
([1 2 1] x [1 2 1] / 16) of the current heights, clipped to within q / 2 of its source height.
No dither, no randomness: a fixed function of the posts within ``passes`` posts, summed in a
fixed order, so a tile with a halo ``passes`` posts wider gives the whole raster's bits. A
plane is kept (the average of a plane is the plane); no height moves by more than q / 2; posts
at the DEM's edges and beside NODATA keep their source heights.

**How much** (``filter_passes``; only a step that shows): each pass spreads a terrace edge by about one post, and a
kink q / h^2 shrinks with the square of its width, so the passes that bring an edge below the
flat threshold H_flat are q / (2 H_flat h^2), rounded down (h the finer post spacing), at most
``MAX_PASSES``. Zero passes: the step is too fine to show in the classes at that spacing (1 mm
at 1 m posts, whole metres at 30 m), and the DEM is classified as it is. Measured on the
corpus' terrain families quantized from 1 cm to 0.5 m at 0.25 to 5 m posts:
``benchmarks/bench_quantized.py`` (docs/method.md has the table).

The store keeps the source heights; the filtered heights feed the curvature and the classes only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SAMPLE_WINDOWS = 16  # windows sampled, on a 4 x 4 lattice over the DEM
SAMPLE_SIDE = 64  # posts per side of each
MAX_PASSES = 32  # the filter's reach, posts: the tiles' halo grows by this much at most
MAX_DIVISOR = 8  # the step may be the smallest gap over 1 .. 8
MIN_ULPS = 64  # a step finer than this many units in the last place is the number type's own lattice
SHOWS = 0.1  # the quantization shows when a window's quadratic leaves this many steps of rms residual
RELIEF_SHOWS = 3.0  # the rounding shows while the post-scale relief is at most this many steps


@dataclass(frozen=True)
class Quantum:
    """A DEM's height step, as found on a sample.

    step : q, m
    levels : distinct heights in the sample
    sampled : posts sampled (with heights)
    low, high : the sample's lowest and highest height, m
    terraces : the share of neighbouring posts (along rows and columns) at one level (treads)
    relief : the median |second difference| (4-neighbour Laplacian) of the sampled heights, in
        steps: the ground's own relief at the post scale against the step's. Rounding alone
        gives about 1 (white rounding noise) or less (treads); the rounding shows in the
        curvature when it is at most ``RELIEF_SHOWS``
    """

    step: float
    levels: int
    sampled: int
    low: float
    high: float
    terraces: float = 0.0
    relief: float = 0.0

    @property
    def shows(self) -> bool:
        """Whether the rounding, not the ground, makes the post-scale curvature."""
        return self.relief <= RELIEF_SHOWS


def sample_windows(rows: int, cols: int, windows: int = SAMPLE_WINDOWS, side: int = SAMPLE_SIDE):
    """(r0, r1, c0, c1) of the sampled windows: a lattice of up to ``windows`` spread over the
    grid (all of a grid up to 256 posts a side), row by row (so a reader that decodes from the
    top goes down once)."""
    k = max(1, int(math.isqrt(windows)))

    def starts(n):
        if n <= k * side:  # a small grid: windows side by side over all of it, none twice
            return list(range(0, n, side))
        return sorted({int(round(v)) for v in np.linspace(0, n - side, k)})

    return [(r, min(r + side, rows), c, min(c + side, cols)) for r in starts(rows) for c in starts(cols)]


def find_quantum(read, rows: int, cols: int, height_dtype: str = "float64") -> Quantum | None:
    """The height step of a DEM, or None (not quantized, or not visibly so).

    read(r0, r1, c0, c1) : heights of a window (float64, NaN at NODATA)
    height_dtype : "float32" when the heights are float32 values (their last place is coarser)
    """
    windows = [read(*w) for w in sample_windows(rows, cols)]
    values = np.concatenate([w[np.isfinite(w)] for w in windows])
    if values.size < 16:
        return None
    levels = np.unique(values)
    if levels.size < 2:
        return None  # one height: no step to see
    ulp = float(np.spacing(np.dtype(height_dtype).type(np.max(np.abs(levels)))))
    tol = 8 * ulp
    gaps = np.diff(levels)
    smallest = float(gaps.min())
    step = None
    for divisor in range(1, MAX_DIVISOR + 1):
        q = smallest / divisor
        if q <= MIN_ULPS * ulp:
            break
        k = np.round(gaps / q)
        q = float((gaps * k).sum() / (k * k).sum())  # the smallest gap's own rounding, averaged out
        if np.all(np.abs(gaps - k * q) <= tol):
            step = q
            break
    if step is None or not _shows(windows, step):
        return None
    return Quantum(step, int(levels.size), int(values.size), float(levels[0]), float(levels[-1]),
                   _level_share(windows), _relief(windows) / step)


def _relief(windows) -> float:
    """The median |4-neighbour Laplacian| (m) over the sampled posts that have their 4 neighbours."""
    parts = []
    for z in windows:
        if z.shape[0] < 3 or z.shape[1] < 3:
            continue
        lap = z[:-2, 1:-1] + z[2:, 1:-1] + z[1:-1, :-2] + z[1:-1, 2:] - 4.0 * z[1:-1, 1:-1]
        parts.append(np.abs(lap[np.isfinite(lap)]))
    values = np.concatenate(parts) if parts else np.zeros(0)
    return float(np.median(values)) if values.size else 0.0


def _level_share(windows) -> float:
    """The share of neighbouring posts (both with heights) at one level."""
    same = pairs = 0
    for z in windows:
        for a, b in ((z[:, 1:], z[:, :-1]), (z[1:], z[:-1])):
            ok = np.isfinite(a) & np.isfinite(b)
            pairs += int(ok.sum())
            same += int((ok & (a == b)).sum())
    return same / pairs if pairs else 0.0


def _shows(windows, step: float) -> bool:
    """Whether quadratics fitted to the windows leave residuals of at least SHOWS steps (rms)."""
    sq, n = 0.0, 0
    for z in windows:
        ok = np.isfinite(z)
        if ok.sum() < 12:
            continue
        r, c = np.nonzero(ok)
        r = (r - r.mean()) / max(1.0, z.shape[0])
        c = (c - c.mean()) / max(1.0, z.shape[1])
        A = np.column_stack([np.ones_like(r), r, c, r * r, r * c, c * c])
        v = z[ok]
        coef, *_ = np.linalg.lstsq(A, v - v.mean(), rcond=None)
        res = v - v.mean() - A @ coef
        sq += float(res @ res)
        n += res.size
    return n > 0 and math.sqrt(sq / n) >= SHOWS * step


def step_hint(quantum: Quantum, dtype: str = "") -> str:
    """A guess at where a step comes from, for messages: " (whole metres?)", " (8-bit?)", ..."""
    q = quantum.step
    if q >= 1 and abs(q - round(q)) < 1e-9 * q:
        return " (whole metres?)" if round(q) == 1 else ""
    decimals = -math.log10(q)
    if abs(decimals - round(decimals)) < 1e-6:
        return f" (rounded to {round(decimals)} decimal{'s' if round(decimals) > 1 else ''}?)"
    if dtype in ("uint8", "int8"):
        return " (8-bit values)"
    if dtype in ("uint16", "int16"):
        return " (16-bit values)"
    if (quantum.high - quantum.low) / q <= 255 + 1e-6:
        return " (8-bit?)"
    return ""


def filter_passes(step: float, dx: float, dy: float, flat_threshold: float) -> int:
    """Smoothing passes for a step at this post spacing (see the module doc): 0 when the step
    cannot show in the classes."""
    h = min(dx, dy)
    if flat_threshold <= 0:
        return MAX_PASSES
    return int(min(MAX_PASSES, math.floor(step / (2.0 * flat_threshold * h * h))))


def smooth_within_quantum(z: np.ndarray, step: float, passes: int) -> np.ndarray:
    """Heights smoothed ``passes`` times within half a step of the source (module doc); NaN
    (NODATA, beyond the grid) stays NaN and its neighbours keep their heights."""
    if passes <= 0:
        return z
    valid = np.isfinite(z)
    rows, cols = z.shape
    if rows < 3 or cols < 3:
        return z
    full = valid[1:-1, 1:-1].copy()
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr or dc:
                full &= valid[1 + dr:rows - 1 + dr, 1 + dc:cols - 1 + dc]
    half = 0.5 * step
    lo = z[1:-1, 1:-1] - half
    hi = z[1:-1, 1:-1] + half
    s = z.copy()
    inner = s[1:-1, 1:-1]
    with np.errstate(invalid="ignore"):
        for _ in range(passes):
            a = s[:, :-2] + 2.0 * s[:, 1:-1] + s[:, 2:]
            b = a[:-2] + 2.0 * a[1:-1] + a[2:]
            inner[...] = np.where(full, np.minimum(np.maximum(b * 0.0625, lo), hi), inner)
    return s
