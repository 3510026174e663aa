"""k-DOPs: discrete oriented polytopes with the standard fixed direction sets.

A k-DOP is the intersection of k/2 slabs lo_i <= d_i . x <= hi_i. The sets
(Klosowski et al. 1998): k = 6 the coordinate axes (the AABB); 14 adds the
four cube diagonals; 18 the six edge diagonals instead; 26 all of them. The
first three directions are always the axes, so every k-DOP carries its AABB.

A k-DOP is not rotation invariant. For a node of the moving tree the bound in
the world is taken from parallelepipeds that contain it: any three of its
slabs with independent directions bound a parallelepiped containing the k-DOP,
whose support along a direction f is f . c + sum_j |f . w_j| r_j (c its centre,
w_j the columns of the inverse of the three directions, r_j the half-widths).
The smallest support over a few such triples is a conservative, and for
thin shapes far tighter than the rotated AABB, bound (tested against the
rotated vertices: it never misses).
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

from tankcd_cli.names import KDOP_KS as KS  # the k-DOP types there are

_AXES = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
_CORNERS = [(1, 1, 1), (1, -1, -1), (1, 1, -1), (1, -1, 1)]
_EDGES = [(1, 1, 0), (1, -1, 0), (1, 0, 1), (1, 0, -1), (0, 1, 1), (0, 1, -1)]
MAX_TRIPLES = 2  # the axes and one diagonal triple: each more tightens little and costs a third more


@lru_cache(maxsize=len(KS))  # a pure function of k, asked once per query batch: one entry per k-DOP type
def directions(k: int) -> np.ndarray:
    """Unit slab directions (k/2, 3) of a k-DOP; the first three are the axes (read-only)."""
    sets = {6: _AXES, 14: _AXES + _CORNERS, 18: _AXES + _EDGES, 26: _AXES + _CORNERS + _EDGES}
    if k not in sets:
        raise ValueError(f"k-DOPs come with k in {KS}, not {k}")
    d = np.array(sets[k], dtype=float)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d.setflags(write=False)
    return d


@lru_cache(maxsize=len(KS))
def triples(k: int) -> np.ndarray:
    """Index triples (t, 3) of independent directions whose parallelepipeds bound a k-DOP under rotation
    (read-only): the axes, then the first well-conditioned triples of the other directions."""
    chosen = [[0, 1, 2]]
    d = directions(k)
    extra = range(3, len(d))
    for t in itertools.combinations(extra, 3):
        if len(chosen) == MAX_TRIPLES:
            break
        if abs(np.linalg.det(d[list(t)])) > 0.3:
            chosen.append(list(t))
    out = np.array(chosen, dtype=np.int64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=len(KS))
def triple_inverses(k: int) -> np.ndarray:
    """Inverses (t, 3, 3) of the triples' direction matrices, whose columns are the w_j (read-only)."""
    d = directions(k)
    W = np.stack([np.linalg.inv(d[t]) for t in triples(k)])
    W.setflags(write=False)
    return W


def fit(points: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k-DOP (lo, hi), each (..., k/2), of point sets (..., p, 3)."""
    proj = points @ directions(k).T
    return proj.min(axis=-2), proj.max(axis=-2)


def overlap(lo_a, hi_a, lo_b, hi_b) -> np.ndarray:
    """Whether k-DOPs overlap (closed: touching counts), broadcast over leading axes."""
    return ((lo_a <= hi_b) & (lo_b <= hi_a)).all(axis=-1)


def rotated_bound(lo: np.ndarray, hi: np.ndarray, k: int, rotation: np.ndarray, translation: np.ndarray):
    """Conservative world k-DOP (lo, hi) of k-DOPs (n, k/2) moved by x -> R x + t (numpy reference)."""
    d = directions(k)
    f = d @ rotation  # rows: R^T d_i, the world directions seen in the body frame
    best_lo = np.full(lo.shape, -np.inf)
    best_hi = np.full(hi.shape, np.inf)
    for t, W in zip(triples(k), triple_inverses(k)):  # W's columns are the w_j
        mid = 0.5 * (lo[:, t] + hi[:, t])
        half = 0.5 * (hi[:, t] - lo[:, t])
        centre = mid @ W.T  # (n, 3): D^-1 mid
        g = f @ W  # (k/2, 3): f_i . w_j
        reach = half @ np.abs(g).T  # (n, k/2)
        c = centre @ f.T
        best_lo = np.maximum(best_lo, c - reach)
        best_hi = np.minimum(best_hi, c + reach)
    shift = d @ translation
    return best_lo + shift, best_hi + shift
