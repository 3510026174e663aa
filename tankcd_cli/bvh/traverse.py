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

from tankcd_cli.bvh._traverse import ALL, FIRST, POSE_CHUNK, brute_force_batch, collide_batch  # noqa: F401
