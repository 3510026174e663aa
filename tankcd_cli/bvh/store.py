"""Trees on disk (HDF5, flat arrays), with what they were built from, so a stale one is caught.

/nodes/lo, /nodes/hi      (n, k/2) float64  node k-DOPs
/nodes/left, /nodes/right (n,) int64        children (-1 at leaves)
/nodes/start, /nodes/count (n,) int64       leaf triangle ranges
/nodes/depth              (n,) int64
/triangles                (m, 3, 3) float64 in leaf order
/source_index             (m,) int64        input index of each triangle
/part                     (m,) uint8        optional: part of the model each triangle belongs to
root attributes: format, format_version, k, aabb_levels, split, leaf_size,
source, source_sha256, placement (what the model's frame was turned and moved by), tankcd_version
"""

from __future__ import annotations

import h5py
import numpy as np

from tankcd_cli import __version__
from tankcd_cli.bvh.build import Tree
from tankcd_cli.errors import InputError
from tankcd_cli.io.h5 import check_indices, open_h5, read_errors

FORMAT = "tankcd-bvh"
FORMAT_VERSION = 1


def write_tree(path: str, tree: Tree, part: np.ndarray | None = None) -> None:
    with h5py.File(path, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION
        h5.attrs["tankcd_version"] = __version__
        for key in ("k", "aabb_levels", "split", "leaf_size"):
            h5.attrs[key] = getattr(tree, key)
        for key, value in tree.attrs.items():
            h5.attrs[key] = value
        for name in ("lo", "hi", "left", "right", "start", "count", "depth"):
            h5[f"nodes/{name}"] = getattr(tree, name)
        h5["triangles"] = tree.triangles
        h5["source_index"] = tree.source_index
        if part is not None:
            h5["part"] = part


def read_tree(path: str) -> tuple[Tree, np.ndarray | None]:
    """The tree and its per-triangle part labels (None if absent)."""
    what = "tankcd tree"
    with open_h5(path, FORMAT, FORMAT_VERSION, what, "build it again") as h5, read_errors(path, what):
        # list() first: a lazily iterated h5py view holds h5py's lock while suspended, and an error in
        # our conversion would leave it suspended (a later garbage collection in another thread deadlocks)
        attrs = {k: (v.decode("utf-8", "replace") if isinstance(v, bytes) else v) for k, v in list(h5.attrs.items())}
        nodes = {name: h5[f"nodes/{name}"][()] for name in ("lo", "hi", "left", "right", "start", "count", "depth")}
        tree = Tree(h5["triangles"][()], h5["source_index"][()], k=int(attrs["k"]),
                    aabb_levels=int(attrs["aabb_levels"]), split=str(attrs["split"]),
                    leaf_size=int(attrs["leaf_size"]), attrs={k: v for k, v in attrs.items()
                                                              if k not in ("k", "aabb_levels", "split", "leaf_size")},
                    **nodes)
        part = h5["part"][()] if "part" in h5 else None
    # the traversal trusts these without bounds checks
    m, count = len(tree.triangles), len(tree.lo)
    check_indices(path, what, tree.left, count, "child")
    check_indices(path, what, tree.right, count, "child")
    check_indices(path, what, tree.source_index, 1 << 62, "source")
    if (tree.triangles.ndim != 3 or tree.triangles.shape[1:] != (3, 3) or not np.isfinite(tree.triangles).all()
            or (tree.start < 0).any() or (tree.count < 0).any() or (tree.start + tree.count > m).any()
            or len(tree.source_index) != m or any(len(a) != count for a in (tree.hi, tree.left, tree.right,
                                                                             tree.start, tree.count, tree.depth))):
        raise InputError(path, f"damaged {what}: inconsistent node or triangle arrays")
    inner = np.flatnonzero(tree.left >= 0)
    if ((tree.right[inner] < 0).any() or (tree.left[inner] <= inner).any() or (tree.right[inner] <= inner).any()
            or (tree.depth[tree.left[inner]] != tree.depth[inner] + 1).any()
            or (tree.depth[tree.right[inner]] != tree.depth[inner] + 1).any() or (count and tree.depth[0] != 0)):
        raise InputError(path, f"damaged {what}: the nodes do not form a tree")
    return tree, part
