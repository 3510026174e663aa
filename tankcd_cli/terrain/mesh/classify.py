"""Classify a terrain read as a mesh (an irregular mesh, or a DEM's posts as triangles): clean-up,
mean curvature, footprint-averaged classes and the point-location index, into a mesh-layout store."""

from __future__ import annotations

import datetime
from typing import Callable

import numpy as np

from tankcd_cli import __version__
from tankcd_cli.errors import InputError, warn
from tankcd_cli.io.terrain_readers import RawTerrain, read_terrain
from tankcd_cli.names import AUTO_METHODS
from tankcd_cli.terrain.curvature.mean import mean_curvature, open_vertices
from tankcd_cli.terrain.mesh.clean import CleanMesh, clean_mesh, height_field_problems
from tankcd_cli.terrain.mesh.footprint_average import class_shares, footprint_curvature, vertex_areas
from tankcd_cli.terrain.mesh.locate import build_buckets
from tankcd_cli.terrain.mesh.store import MeshStore
from tankcd_cli.terrain.regions import NO_CLASS, Thresholds, classify_values, default_thresholds
from tankcd_cli.tolerances import DEFAULT, Tolerances
from tankcd_cli.vehicle import Vehicle, vehicle_preset


def classify_mesh(raw: RawTerrain, method: str = "auto", vehicle: Vehicle | None = None,
                  thresholds: Thresholds | None = None, tol: Tolerances = DEFAULT,
                  progress: Callable[[str], None] | None = None) -> MeshStore:
    """Clean a terrain, compute mean curvature and region classes, and build the query indexes.

    method : one of ``CURVATURE_METHODS``, or "auto" (``AUTO_METHODS``: jet on a mesh, cotan on a
        DEM's regular triangles)
    """
    say = progress or (lambda stage: None)
    if method == "auto":
        method = AUTO_METHODS["mesh" if raw.grid is None else "dem_as_mesh"]
    vehicle = vehicle or vehicle_preset("t72")
    thresholds = thresholds or default_thresholds(vehicle)

    if raw.grid is None:
        say("cleaning mesh")
        mesh = clean_mesh(raw.vertices, raw.faces, tol)
        if len(mesh.faces) == 0:
            raise InputError(raw.source, "no usable faces: every face is degenerate (zero area)")
        grid = None
    else:
        # DEM posts are distinct and their triangles have the cell's area: nothing to clean
        mesh = CleanMesh(raw.vertices, raw.faces, np.arange(len(raw.vertices)),
                         {"merged_vertices": 0, "degenerate_faces": 0, "repeated_faces": 0, "unreferenced_vertices": 0})
        grid = raw.grid
    vertices, faces = mesh.vertices, mesh.faces

    say(f"mean curvature ({method}) at {len(vertices):,} vertices")
    open_verts = open_vertices(faces, len(vertices))
    H = mean_curvature(vertices, faces, method, tol, open_verts=open_verts)
    if not np.isfinite(H).all():
        raise RuntimeError(f"{int((~np.isfinite(H)).sum())} non-finite curvature values")

    say("region classes")
    area = vertex_areas(vertices, faces)
    averaged, raster = footprint_curvature(vertices, H, area, vehicle)
    classes = classify_values(averaged, thresholds)
    class_raster = np.where(np.isfinite(raster.values), classify_values(np.nan_to_num(raster.values), thresholds),
                            NO_CLASS).astype(np.uint8)
    shares = class_shares(classes, area)

    buckets = None
    if grid is None:  # a DEM's post raster locates points by itself
        say("point-location index")
        buckets = build_buckets(vertices, faces)

    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    attrs = {
        "tankcd_version": __version__,
        "created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "source": raw.source,
        "source_sha256": raw.sha256,
        "source_format": raw.format,
        "source_up_axis": raw.up,
        "curvature_method": method,
        "boundary_treatment": "one-sided quartic fit over the 40 nearest vertices",
        "threshold_flat": thresholds.flat,
        "threshold_uneven": thresholds.uneven,
        "threshold_derivation": thresholds.derivation,
        "class_average": "area-weighted mean of |H| (H first averaged over a disk of radius track_length/4) over a disk of radius track_length/2",
        "vehicle": vehicle.name,
        "track_length": vehicle.track_length,
        "track_width": vehicle.track_width,
        "share_flat": shares[0], "share_general": shares[1], "share_uneven": shares[2],
        "extent_min": lo, "extent_max": hi,
        "vertices_read": len(raw.vertices), "faces_read": len(raw.faces),
        "boundary_vertices": int(open_verts.boundary.sum()),
        "nonmanifold_vertices": int(open_verts.nonmanifold.sum()),
        "is_grid": raw.grid is not None,
    }
    for key, value in mesh.counts.items():
        attrs[key] = value
    return MeshStore(vertices, faces, H, averaged, classes, class_raster, raster.values.astype(np.float32),
                     raster.origin, raster.cell, buckets, grid, attrs)


def read_mesh(path: str, up: str | None = None, fmt: str | None = None) -> RawTerrain:
    """A terrain file read as a mesh (``io.terrain_readers.read_terrain``); a mesh that does not
    look like a terrain seen from above is a warning (``warn_if_not_a_height_field``)."""
    raw = read_terrain(path, up=up, fmt=fmt)
    if raw.grid is None:
        warn_if_not_a_height_field(raw)
    return raw


def raw_terrain_of(store: MeshStore, path: str) -> RawTerrain:
    """A mesh-layout store's cleaned mesh as a RawTerrain, to classify again; its provenance is the
    store's source (``path`` where the store names none)."""
    a = store.attrs
    return RawTerrain(store.vertices, store.faces, store.grid, a.get("source", path), a.get("source_sha256", ""),
                      a.get("source_format", "h5"), a.get("source_up_axis", "z"))


def warn_if_not_a_height_field(raw: RawTerrain) -> None:
    """A warning when a mesh read as a terrain does not look like one (see ``height_field_problems``),
    saying whether the other up axis would make it one."""
    problems = height_field_problems(raw.vertices, raw.faces)
    if not problems:
        return
    v = raw.vertices
    # the other reading: undo or apply the y-up turn (x, y, z) -> (x, -z, y)
    other, other_up = ((np.column_stack([v[:, 0], v[:, 2], -v[:, 1]]), "z") if raw.up == "y"
                       else (np.column_stack([v[:, 0], -v[:, 2], v[:, 1]]), "y"))
    advice = (f"read with --up {other_up} it would look like one" if not height_field_problems(other, raw.faces)
              else "a terrain is a surface seen from above, not a closed object")
    warn(raw.source, f"does not look like a terrain seen from above with {raw.up} up: {'; '.join(problems)}; "
                     + advice)
