"""A plain summary of a terrain store, for ``tankcd info``."""

from __future__ import annotations

import os

from tankcd_cli.errors import InputError


def describe_store(path: str) -> dict:
    """Facts about a store as an ordered dict of plain values."""
    import h5py

    from tankcd_cli.io.h5 import read_errors
    from tankcd_cli.terrain.store import is_store, read_attrs

    if not os.path.exists(path):
        raise InputError(path, "no such file")
    if not is_store(path):
        if path.lower().endswith(".toml"):
            from tankcd_cli.replay.scene import load_scene

            return load_scene(path).describe()
        raise InputError(path, "not an HDF5 store or a scene (tankcd info describes stores, trees and scenes)")
    with read_errors(path, "HDF5 file"):
        with h5py.File(path, "r") as h5:
            kind = h5.attrs.get("format")
    if isinstance(kind, bytes):
        kind = kind.decode("utf-8", "replace")
    if kind == "tankcd-bvh":
        from tankcd_cli.bvh.store import read_tree

        tree, part = read_tree(path)
        facts = {"file": path, "kind": "bounding-volume tree"}
        facts.update({k: v for k, v in tree.attrs.items() if k in ("source", "source_sha256", "placement", "tankcd_version")})
        facts.update(tree.describe())
        return facts
    with read_errors(path, "tankcd terrain store"):
        a = read_attrs(path)
        if a.get("layout") == "grid":
            return _describe_grid(path, a)
        with h5py.File(path, "r") as h5:
            n = h5["mesh/vertices"].shape[0]
            m = h5["mesh/faces"].shape[0]
            raster = h5["classes/raster"].shape
            grid = h5["grid/vertex"].shape if "grid/vertex" in h5 else None
        lo, hi = a.get("extent_min", [0, 0, 0]), a.get("extent_max", [0, 0, 0])
        return {
            "file": path,
            "kind": "terrain store (format %s v%s)" % (a.get("format"), a.get("format_version")),
            "source": a.get("source"),
            "source sha256": a.get("source_sha256"),
            "source format": a.get("source_format"),
            "written by": f"tankcd {a.get('tankcd_version')} at {a.get('created_utc')}",
            "vertices": n,
            "faces": m,
            "DEM grid": f"{grid[0]} x {grid[1]} posts" if grid else "no (irregular mesh: triangle buckets)",
            "extent x": [lo[0], hi[0]],
            "extent y": [lo[1], hi[1]],
            "extent z": [lo[2], hi[2]],
            **_classes(a),
            "class raster": f"{raster[0]} x {raster[1]} cells",
            "clean-up": (f"{a.get('merged_vertices')} merged, {a.get('unreferenced_vertices')} unreferenced vertices; "
                         f"{a.get('degenerate_faces')} degenerate, {a.get('repeated_faces')} repeated faces dropped"),
        }


def _describe_grid(path: str, a: dict) -> dict:
    """Facts about a grid-layout store (reads attributes only, never a raster)."""
    import h5py

    with h5py.File(path, "r") as h5:
        h = h5["grid/height"]
        rows, cols = h.shape
        dtype = h.dtype.name
        chunks = h.chunks
        spacing = [float(s) for s in h.attrs["spacing"]]
        origin = [float(h.attrs["origin_x"]), float(h.attrs["origin_y"])]
        crs_name = h.attrs.get("crs_name", "")
        crs = h.attrs.get("crs", "")
    crs_name = crs_name.decode("utf-8", "replace") if isinstance(crs_name, bytes) else str(crs_name)
    crs = crs.decode("utf-8", "replace") if isinstance(crs, bytes) else str(crs)
    lo, hi = a.get("extent_min", [0, 0, 0]), a.get("extent_max", [0, 0, 0])
    size = os.path.getsize(path)
    facts = {
        "file": path,
        "kind": "terrain store, grid layout (format %s v%s)" % (a.get("format"), a.get("format_version")),
        "source": a.get("source"),
        "source sha256": a.get("source_sha256"),
        "source format": a.get("source_format"),
        "written by": f"tankcd {a.get('tankcd_version')} at {a.get('created_utc')}",
        "crs": crs_name or ("local grid (no CRS)" if not crs else "unnamed CRS"),
        "reprojected from": a.get("source_crs_name") if a.get("reprojected") else None,
        "grid": f"{rows} x {cols} posts",
        "posts": rows * cols,
        "posts with data": a.get("valid_posts"),
        "post spacing": spacing,
        "north-west post": origin,
        "extent x": [lo[0], hi[0]],
        "extent y": [lo[1], hi[1]],
        "extent z": [lo[2], hi[2]],
        "size km": [round((hi[0] - lo[0]) / 1000, 3), round((hi[1] - lo[1]) / 1000, 3)],
        "cells split": f"along the {a.get('diagonal')} diagonal",
        "tiles": f"{chunks[0]} x {chunks[1]} posts" if chunks else "none",
        "heights": dtype,
        "bytes per post": round(size / max(rows * cols, 1), 2),
        **_classes(a),
    }
    return {k: v for k, v in facts.items() if v is not None}


def _classes(a: dict) -> dict:
    """How a store's classes were made, and their area shares."""
    return {
        "curvature method": a.get("curvature_method"),
        "boundary treatment": a.get("boundary_treatment"),
        "class average": a.get("class_average"),
        "vehicle": a.get("vehicle"),
        "threshold flat": a.get("threshold_flat"),
        "threshold uneven": a.get("threshold_uneven"),
        "thresholds from": a.get("threshold_derivation"),
        "area flat": f"{a.get('share_flat', 0):.1%}",
        "area general": f"{a.get('share_general', 0):.1%}",
        "area uneven": f"{a.get('share_uneven', 0):.1%}",
    }
