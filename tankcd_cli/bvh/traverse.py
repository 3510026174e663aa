"""Tandem depth-first traversal of two trees, batched over poses, compiled ahead of time (Cython).

Tree A moves (a vehicle, its triangles in its own frame, placed by x -> R x + t
at each pose); tree B is static (an obstacle in the world). Each pose walks
the two trees together from the roots, depth first as in the paper: a pair of
nodes whose volumes are disjoint is dropped, otherwise the larger node is
opened, and at two leaves their triangles are tested exactly. The volume test
of a pair is the AABB test when either node lies in its tree's AABB levels,
the k-DOP test below. A's volume at a pose is the conservative moved k-DOP of
``geometry.kdop``. Poses run in parallel threads ("same-layer subtasks in
parallel", OpenMP threads taking poses ``POSE_CHUNK`` at a time, since a clear
pose ends at the roots and a grazing one goes deep); within a pose the walk is
sequential, so "first contact" can stop at the first hit.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tankcd_cli.bvh._traverse import ALL, FIRST, POSE_CHUNK, brute_force_batch, collide_batch  # noqa: F401


class MovingTree(NamedTuple):
    """The arrays of the moving tree (A) the walk reads (see ``bvh.build.Tree``)."""

    triangles: np.ndarray  # (m, 3, 3) in leaf order, the tree's own frame
    index: np.ndarray  # (m,) input index of each triangle
    left: np.ndarray
    right: np.ndarray
    start: np.ndarray
    count: np.ndarray
    depth: np.ndarray
    aabb_levels: int
    centre: np.ndarray  # (n, T, 3) slab-triple parallelepipeds: the volume under any rigid motion
    half: np.ndarray
    size: np.ndarray  # (n,) a node's size (which node of a pair to open)

    @classmethod
    def of(cls, tree) -> "MovingTree":
        return cls(tree.triangles, tree.source_index, tree.left, tree.right, tree.start, tree.count, tree.depth,
                   tree.aabb_levels, tree.centre, tree.half, node_size(tree))


class StaticTree(NamedTuple):
    """The arrays of the static tree (B) the walk reads."""

    triangles: np.ndarray
    index: np.ndarray
    lo: np.ndarray  # (n, k/2) node k-DOPs
    hi: np.ndarray
    left: np.ndarray
    right: np.ndarray
    start: np.ndarray
    count: np.ndarray
    depth: np.ndarray
    aabb_levels: int
    size: np.ndarray

    @classmethod
    def of(cls, tree) -> "StaticTree":
        return cls(tree.triangles, tree.source_index, tree.lo, tree.hi, tree.left, tree.right, tree.start, tree.count,
                   tree.depth, tree.aabb_levels, node_size(tree))


def node_size(tree) -> np.ndarray:
    """A node's size for choosing which node of a pair to open: the sum of its AABB's sides."""
    return (tree.hi[:, :3] - tree.lo[:, :3]).sum(axis=1)
