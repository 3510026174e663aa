"""Top-down construction of a binary bounding-volume tree over triangles, level by level.

Split rules (``SPLITS``):

``median``  the median of the triangle centroids along the longest axis of
            their extent (balanced trees, the paper's splitting plane);
``sah``     the surface-area heuristic over 16 bins along that axis: the
            split that minimises area(left) * count(left) + area(right) *
            count(right), the expected cost of a ray or overlap query
            (MacDonald and Booth 1990), falling back to the median when a
            node's centroids coincide.

All nodes of a level are split at once with array operations: no Python loop
over nodes, so a 1M-triangle model builds in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tankcd_cli.geometry import kdop
from tankcd_cli.names import SPLITS  # noqa: F401 (the split rules there are)

SAH_BINS = 16


@dataclass
class Tree:
    """A flat binary tree.

    triangles : (m, 3, 3) float64, in leaf order (a leaf holds triangles[start:start + count])
    source_index : (m,) int64 -- the input index of each triangle
    lo, hi : (n, k/2) node k-DOPs; left, right : (n,) int64 children (-1 at leaves)
    start, count : (n,) leaf ranges (count 0 at inner nodes); depth : (n,) int64
    k, aabb_levels : volume type and how many top levels use only the AABB slabs
    centre, half : (n, T, 3) per node and per slab triple: the parallelepiped that
        bounds the node under any rigid motion (see geometry.kdop)
    """

    triangles: np.ndarray
    source_index: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    left: np.ndarray
    right: np.ndarray
    start: np.ndarray
    count: np.ndarray
    depth: np.ndarray
    k: int
    aabb_levels: int
    split: str
    leaf_size: int
    centre: np.ndarray = field(repr=False, default=None)
    half: np.ndarray = field(repr=False, default=None)
    attrs: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.centre is None:
            self.centre, self.half = parallelepipeds(self.lo, self.hi, self.k)

    @property
    def nodes(self) -> int:
        return len(self.left)

    def describe(self) -> dict:
        leaves = self.left < 0
        per_level = np.bincount(self.depth)
        return {
            "triangles": int(len(self.triangles)), "nodes": int(self.nodes), "depth": int(self.depth.max()),
            "k": self.k, "aabb_levels": self.aabb_levels, "split": self.split, "leaf_size": self.leaf_size,
            "nodes_per_level": per_level.tolist(),
            "aabb_nodes": int((self.depth < self.aabb_levels).sum()),
            "kdop_nodes": int((self.depth >= self.aabb_levels).sum()),
            "leaves": int(leaves.sum()),
            "leaf_triangles_mean": float(self.count[leaves].mean()) if leaves.any() else 0.0,
            "leaf_triangles_max": int(self.count[leaves].max()) if leaves.any() else 0,
        }


def parallelepipeds(lo: np.ndarray, hi: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Centres and half-widths (n, T, 3) of the slab-triple parallelepipeds of each node."""
    trip = kdop.triples(k)
    inverses = kdop.triple_inverses(k)
    centre = np.empty((len(lo), len(trip), 3))
    half = np.empty((len(lo), len(trip), 3))
    for t, idx in enumerate(trip):
        W = inverses[t]
        centre[:, t] = (0.5 * (lo[:, idx] + hi[:, idx])) @ W.T
        half[:, t] = 0.5 * (hi[:, idx] - lo[:, idx])
    return centre, half


def build_tree(triangles: np.ndarray, k: int = 18, leaf_size: int = 4, aabb_levels: int = 2,
               split: str = "sah") -> Tree:
    """Build a tree over triangles (m, 3, 3) float64 (degenerate ones are kept: they cannot collide)."""
    if split not in SPLITS:
        raise ValueError(f"unknown split rule {split!r}; choose one of {', '.join(SPLITS)}")
    triangles = np.ascontiguousarray(triangles, dtype=np.float64)
    m = len(triangles)
    if m == 0:
        raise ValueError("no triangles to build a tree over")
    centroid = triangles.mean(axis=1)
    tri_lo, tri_hi = kdop.fit(triangles, k)
    perm = np.arange(m)

    # level-by-level split; nodes are numbered in creation order (parents before children)
    cap = 2 * m
    node_start = np.zeros(cap, dtype=np.int64)
    node_count = np.zeros(cap, dtype=np.int64)
    node_depth = np.zeros(cap, dtype=np.int64)
    left = np.full(cap, -1, dtype=np.int64)
    right = np.full(cap, -1, dtype=np.int64)
    node_count[0] = m
    level = np.array([0])
    n = 1
    while True:
        ids = level[node_count[level] > leaf_size]
        if len(ids) == 0:
            break
        s, c = node_start[ids], node_count[ids]
        # the elements of the nodes being split, labelled by node
        owner = np.repeat(np.arange(len(ids)), c)
        elem = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c) + np.repeat(s, c)
        pts = centroid[perm[elem]]
        seg = np.cumsum(c) - c  # each node's elements are contiguous
        lo = np.minimum.reduceat(pts, seg, axis=0)
        hi = np.maximum.reduceat(pts, seg, axis=0)
        axis = np.argmax(hi - lo, axis=1)
        key = pts[np.arange(len(pts)), axis[owner]]
        order = np.lexsort((key, owner))
        perm[elem] = perm[elem[order]]
        key = key[order]
        cut = _sah_cut(tri_lo, tri_hi, perm, elem, owner, key, lo, hi, axis, c) if split == "sah" else c // 2
        cut = np.clip(cut, 1, c - 1)
        lid = n + 2 * np.arange(len(ids))
        rid = lid + 1
        n += 2 * len(ids)
        left[ids], right[ids] = lid, rid
        node_start[lid], node_count[lid] = s, cut
        node_start[rid], node_count[rid] = s + cut, c - cut
        node_depth[lid] = node_depth[rid] = node_depth[ids] + 1
        level = np.concatenate([lid, rid])
    start, count, node_depth, left, right = node_start[:n], node_count[:n], node_depth[:n], left[:n], right[:n]
    leaf = left < 0
    count = np.where(leaf, count, 0)

    # bounds: leaves from their triangles, inner nodes from their children, deepest first
    lo = np.empty((n, tri_lo.shape[1]))
    hi = np.empty((n, tri_lo.shape[1]))
    leaf_ids = np.flatnonzero(leaf)
    o = np.argsort(start[leaf_ids])
    leaf_ids = leaf_ids[o]
    lo[leaf_ids] = np.minimum.reduceat(tri_lo[perm], start[leaf_ids], axis=0)
    hi[leaf_ids] = np.maximum.reduceat(tri_hi[perm], start[leaf_ids], axis=0)
    for d in range(int(node_depth.max()) - 1, -1, -1):
        inner = np.flatnonzero((node_depth == d) & ~leaf)
        lo[inner] = np.minimum(lo[left[inner]], lo[right[inner]])
        hi[inner] = np.maximum(hi[left[inner]], hi[right[inner]])
    return Tree(triangles[perm], perm.astype(np.int64), lo, hi, left, right, start, count, node_depth, k,
                int(aabb_levels), split, int(leaf_size))


def _sah_cut(tri_lo, tri_hi, perm, elem, owner, key, lo, hi, axis, count):
    """Binned SAH cut (number of elements going left) for every node being split."""
    nodes = len(count)
    span = hi[np.arange(nodes), axis] - lo[np.arange(nodes), axis]
    base = lo[np.arange(nodes), axis]
    safe = np.where(span > 0, span, 1.0)
    b = np.clip(((key - base[owner]) / safe[owner] * SAH_BINS).astype(np.int64), 0, SAH_BINS - 1)
    slot = owner * SAH_BINS + b
    tlo, thi = tri_lo[perm[elem], :3], tri_hi[perm[elem], :3]  # the triangles' AABBs: the k-DOPs' first slabs
    bin_lo = np.full((nodes * SAH_BINS, 3), np.inf)
    bin_hi = np.full((nodes * SAH_BINS, 3), -np.inf)
    # the elements are sorted by node and, within a node, by the key the bins cut: so by slot,
    # and each slot's elements are one run (reduceat, not the much slower ufunc.at)
    first = np.flatnonzero(np.diff(slot, prepend=-1))
    bin_lo[slot[first]] = np.minimum.reduceat(tlo, first, axis=0)
    bin_hi[slot[first]] = np.maximum.reduceat(thi, first, axis=0)
    bin_n = np.bincount(slot, minlength=nodes * SAH_BINS).reshape(nodes, SAH_BINS)
    bin_lo = bin_lo.reshape(nodes, SAH_BINS, 3)
    bin_hi = bin_hi.reshape(nodes, SAH_BINS, 3)

    def area(low, high):
        e = np.where(np.isfinite(high - low), np.maximum(high - low, 0), 0)
        return 2 * (e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 0] * e[..., 2])
    left_lo = np.minimum.accumulate(bin_lo, axis=1)
    left_hi = np.maximum.accumulate(bin_hi, axis=1)
    right_lo = np.minimum.accumulate(bin_lo[:, ::-1], axis=1)[:, ::-1]
    right_hi = np.maximum.accumulate(bin_hi[:, ::-1], axis=1)[:, ::-1]
    n_left = np.cumsum(bin_n, axis=1)
    # cut after bin j (j = 0 .. B-2)
    cost = area(left_lo[:, :-1], left_hi[:, :-1]) * n_left[:, :-1] + \
        area(right_lo[:, 1:], right_hi[:, 1:]) * (count[:, None] - n_left[:, :-1])
    cost = np.where((n_left[:, :-1] > 0) & (n_left[:, :-1] < count[:, None]), cost, np.inf)
    best = np.argmin(cost, axis=1)
    cut = n_left[np.arange(nodes), best]
    return np.where(np.isfinite(cost[np.arange(nodes), best]) & (span > 0), cut, count // 2)
