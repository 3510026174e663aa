"""A plain summary of any file tankcd reads or writes, for ``tankcd info``: a terrain store, a
tree, a scene, a trajectory, a raw terrain (``describe_terrain``: a DEM, a heightmap, a mesh) and
replay's outputs (``describe_outputs``: events, poses CSV, Parquet poses and events, a replay
summary, fleet.json).

What a file is comes from its content where its name does not decide: an HDF5 store or tree by its
signature and attributes, Parquet by its magic number and its ``tankcd.table``, JSON by the keys of
its first object, a trajectory by the trajectory reader's registry of input formats
(``io.trajectory.formats``), a terrain by the terrain readers' (``terrain.open.terrain_kind``).

Facts are ordered dicts of plain values (numbers, strings, lists, nested dicts)
with snake_case keys: ``info --json`` prints them as they are, the text output
spells the keys with spaces. One convention for every pair: coordinates, sizes and
spacings are [x, y] or [x, y, z] lists, ranges (``extent_*``) [min, max], bounds
{"min": [x, y, z], "max": [x, y, z]}, grid shapes {"rows", "columns"} (row 0 the north),
and area shares fractions from 0 to 1 (``area_fraction_*``)."""

from __future__ import annotations

import os

from tankcd_cli.errors import InputError
from tankcd_cli.io.trajectory.formats import DEFAULT_FORMAT, FAMILIES, input_format, trajectory_format
from tankcd_cli.io.trajectory.info import trajectory_info
from tankcd_cli.replay.effects import effects_for


WHAT_INFO_DESCRIBES = ("not a file tankcd reads or writes: not a terrain store, a tree, a scene, a trajectory "
                       f"({', '.join(FAMILIES)}), a DEM, a heightmap, a terrain mesh, events, poses, Parquet "
                       "poses or events, a replay summary or fleet.json")


def describe_store(path: str, scene: str | None = None) -> dict:
    """Facts about any file ``tankcd info`` describes (the module doc), as an ordered dict of
    plain values (``scene``: with a trajectory, which vehicle of that scene each entity is). A
    file that is none of them, or that its reader refuses, is an InputError (exit 3)."""
    import h5py

    from tankcd_cli.io.h5 import read_errors
    from tankcd_cli.io.h5 import is_hdf5
    from tankcd_cli.terrain.store import read_attrs

    if not os.path.exists(path):
        raise InputError(path, "no such file")
    if os.path.isdir(path):
        raise InputError(path, "is a directory: info describes one file")
    if not is_hdf5(path):
        return _describe_other(path, scene)
    with read_errors(path, "HDF5 file"):
        with h5py.File(path, "r") as h5:
            kind = h5.attrs.get("format")
    if isinstance(kind, bytes):
        kind = kind.decode("utf-8", "replace")
    if kind == "tankcd-bvh":
        from tankcd_cli.bvh.store import read_tree

        tree, part = read_tree(path)
        facts = {"file": path, "kind": "bounding-volume tree"}
        facts.update({k: v for k, v in tree.attrs.items() if k in ("source", "source_sha256", "tankcd_version")})
        if "placement" in tree.attrs:  # written as JSON text by the obstacle cache: an object here
            import json

            try:
                facts["placement"] = json.loads(tree.attrs["placement"])
            except (TypeError, ValueError):
                facts["placement"] = str(tree.attrs["placement"])
        facts.update(tree.describe())
        facts["bounds"] = {"min": [float(v) for v in tree.lo[0, :3]], "max": [float(v) for v in tree.hi[0, :3]]}
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
            "kind": "terrain store",
            "layout": "mesh",
            **_provenance(a),
            "vertices": n,
            "faces": m,
            "dem_grid_posts": _shape(grid) if grid else None,  # None: an irregular mesh
            "extent_x": [lo[0], hi[0]],
            "extent_y": [lo[1], hi[1]],
            "extent_z": [lo[2], hi[2]],
            **_classes(a),
            "class_raster_cells": _shape(raster),
            "clean_up": {"merged_vertices": a.get("merged_vertices"),
                         "unreferenced_vertices": a.get("unreferenced_vertices"),
                         "degenerate_faces": a.get("degenerate_faces"), "repeated_faces": a.get("repeated_faces")},
        }


def _describe_other(path: str, scene: str | None) -> dict:
    """Any file but an HDF5 one, by what its content (or, where the content cannot say, its
    reader's suffix rules) says it is."""
    from tankcd_cli import describe_outputs as outputs

    if outputs.is_parquet_file(path):
        return outputs.describe_parquet(path)
    if path.lower().endswith(".toml"):
        return describe_scene(path)
    if os.path.getsize(path) == 0:
        raise InputError(path, "file is empty")
    kind = outputs.json_kind(path)
    if kind in ("events", "summary", "fleet"):
        return outputs.describe_json(path, kind)
    if outputs.is_poses_csv(path):  # what replay writes, not a trajectory to read
        return outputs.describe_poses_csv(path)
    # a terrain first: its readers go by a suffix of their own or by magic bytes, where the trajectory
    # reader takes any XML for GPX (a VRT mosaic, a Collada or XDMF mesh are XML too)
    terrain = _raw_terrain_kind(path)
    if terrain is not None:
        from tankcd_cli import describe_terrain

        return {"raster": describe_terrain.describe_raster, "esri_ascii": describe_terrain.describe_raster,
                "heightmap": describe_terrain.describe_heightmap, "mesh": describe_terrain.describe_mesh}[terrain](path)
    if trajectory_format(path) != DEFAULT_FORMAT:  # the trajectory reader knows it by name or bytes (GPX, a capture)
        return describe_trajectory(path, scene)
    if kind == "json":  # JSON, and no mesh either (a glTF is JSON too)
        return outputs.describe_json(path, kind)
    try:  # what is left is a CSV to the trajectory reader
        return describe_trajectory(path, scene)
    except InputError:
        if _looks_like_csv(path):
            raise  # the reader's own words: the line and what is wrong with it
        raise InputError(path, WHAT_INFO_DESCRIBES) from None


def _raw_terrain_kind(path: str) -> str | None:
    """``raster``, ``esri_ascii``, ``heightmap`` or ``mesh`` for a terrain input that is not a store
    (``terrain.open.terrain_kind``; a mesh only with a suffix a mesh reader knows, since the terrain
    readers take anything else for a mesh and judge it when reading), else None."""
    from tankcd_cli.terrain.open import terrain_kind

    kind = terrain_kind(path)
    if kind in ("raster", "esri_ascii", "heightmap"):
        return kind
    from tankcd_cli.io.terrain_readers import known_formats

    return "mesh" if os.path.splitext(path)[1].lower().lstrip(".") in known_formats() else None


def _looks_like_csv(path: str) -> bool:
    """Whether the file's first line is text with a comma (a CSV the reader refused, not some other file)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    if b"\0" in head:
        return False
    first = head.lstrip().split(b"\n", 1)[0]
    try:
        first.decode("utf-8-sig")
    except UnicodeDecodeError:
        return False
    return b"," in first


def _shape(shape) -> dict:
    """A grid's shape, its order said: {"rows": ..., "columns": ...}."""
    return {"rows": int(shape[0]), "columns": int(shape[1])}


def _provenance(a: dict) -> dict:
    """What a store says of where it came from (both layouts)."""
    keys = ("format", "format_version", "source", "source_sha256", "source_format", "tankcd_version", "created_utc")
    return {k: a.get(k) for k in keys}


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
        "kind": "terrain store",
        "layout": "grid",
        **_provenance(a),
        "crs": crs_name or ("local grid (no CRS)" if not crs else "unnamed CRS"),
        "reprojected_from": a.get("source_crs_name") if a.get("reprojected") else None,
        "source_point_scale": _point_scale(a),
        "grid_posts": _shape((rows, cols)),
        "posts": rows * cols,
        "posts_with_data": a.get("valid_posts"),
        "post_spacing": spacing,
        "north_west_post": origin,
        "extent_x": [lo[0], hi[0]],
        "extent_y": [lo[1], hi[1]],
        "extent_z": [lo[2], hi[2]],
        "size_km": [round((hi[0] - lo[0]) / 1000, 3), round((hi[1] - lo[1]) / 1000, 3)],
        "diagonal": a.get("diagonal"),  # each cell split along it
        "tile_posts": _shape(chunks) if chunks else None,
        "heights": dtype,
        "bytes_per_post": round(size / max(rows * cols, 1), 2),
        "heightmap": _heightmap_reading(a.get("heightmap")),
        "height_quantum": _height_quantum(a),
        "post_spacing_against_track": _spacing_against_track(spacing, a),
        **_classes(a),
    }
    return {k: v for k, v in facts.items() if v is not None}


def _point_scale(a: dict) -> dict | None:
    """A projected source CRS's point scale (its metres over ground metres) at the centre and its
    range over the extent, or None when the source was not in a projected CRS."""
    scale = float(a.get("source_point_scale", 0.0) or 0.0)
    if scale <= 0:
        return None
    low, high = (float(v) for v in a.get("source_point_scale_range", (scale, scale)))
    return {"centre": round(scale, 6), "range": [round(low, 6), round(high, 6)],
            "ground_metres_per_crs_metre": round(1 / scale, 6)}


def _heightmap_reading(text) -> dict | None:
    """How a heightmap's values became posts (the store's ``heightmap`` attribute), or None."""
    if not text:
        return None
    import json

    try:
        return json.loads(text)
    except (TypeError, ValueError):
        return {"reading": str(text)}


def _height_quantum(a: dict) -> dict:
    """The height step classify found (m) and what it did about it (docs/formats.md)."""
    if "height_quantum" not in a:
        return {"step": None, "classes": "unknown: a store written before tankcd looked for a step (classify again)"}
    step = float(a["height_quantum"])
    passes = int(a.get("quantum_filter_passes", 0))
    if not step:
        return {"step": None, "classes": "no common step found in the sampled heights"}
    terraces = float(a.get("height_quantum_terraces", 0.0))
    relief = float(a.get("height_quantum_relief", 0.0))
    if passes:
        done = f"taken from heights smoothed within half a step ({passes} passes), not the terraces"
    elif a.get("height_quantum_shows"):
        done = "classified as they are: the step is too fine to show at these posts"
    else:
        done = "classified as they are: the ground's own relief at the post scale is larger than the step's"
    return {"step": step, "levels": int(a.get("height_quantum_levels", 0)),
            "sampled_posts": int(a.get("height_quantum_sampled_posts", 0)), "on_one_level": round(terraces, 4),
            "relief_in_steps": round(relief, 3), "smoothing_passes": passes, "classes": done}


def _spacing_against_track(spacing, a: dict) -> dict | None:
    """The post spacing against the vehicle's track length, m (posts wider than half of it are coarse)."""
    track = a.get("track_length")
    if not track:
        return None
    widest = max(spacing)
    ratio = widest / float(track)
    verdict = ("too coarse: posts wider than half the track length cannot resolve the ground the tracks feel"
               if ratio > 0.5 else "fine enough: at most half the track length")
    return {"spacing": widest, "track_length": float(track), "ratio": round(ratio, 4), "verdict": verdict}


def _classes(a: dict) -> dict:
    """How a store's classes were made, and their area shares."""
    return {
        "curvature_method": a.get("curvature_method"),
        "boundary_treatment": a.get("boundary_treatment"),
        "class_average": a.get("class_average"),
        "vehicle": a.get("vehicle"),
        "threshold_flat": a.get("threshold_flat"),
        "threshold_uneven": a.get("threshold_uneven"),
        "thresholds_from": a.get("threshold_derivation"),
        "area_fraction_flat": float(a.get("share_flat", 0.0)),
        "area_fraction_general": float(a.get("share_general", 0.0)),
        "area_fraction_uneven": float(a.get("share_uneven", 0.0)),
    }


def describe_trajectory(path: str, scene: str | None = None) -> dict:
    """A trajectory input read once (``io.trajectory.info.trajectory_info``): its format and coordinates,
    rows and time span, its entities (rows or updates, time span, pieces of motion, and with a
    scene the vehicle each is), and what was skipped (a capture's other packets and PDUs)."""
    import math

    info = trajectory_info(path)
    kinds = None
    if scene is not None:
        from tankcd_cli.scene import load_scene

        sc = load_scene(scene)
        labels = ["[vehicle] " + sc.vehicle.name] + [f"[[entity]] {t.label}: {t.vehicle.name}" for t in sc.entities]
        kinds = lambda name: labels[sc.entity_vehicle(name)]  # noqa: E731
    kind = input_format(info.format).kind
    finite = lambda v: None if v is None or not math.isfinite(v) else round(float(v), 6)  # noqa: E731
    entities = []
    for e in info.entities:
        entry = {"name": e.name, "rows": e.rows, "t_first": finite(e.t_first), "t_last": finite(e.t_last),
                 f"first_{info.where}": e.first_line, f"last_{info.where}": e.last_line, "pieces": e.pieces}
        if kinds is not None:
            entry["vehicle"] = kinds(e.name)
        entities.append(entry)
    return {"file": path, "kind": kind, "format": info.format, "coordinates": info.coordinates,
            "rows": info.rows, "t_first": finite(info.t_first), "t_last": finite(info.t_last),
            "start_utc": info.start.isoformat() if info.start is not None else None, "time_origin": info.time_origin,
            "turret_and_gun": info.has_turret, "entities": entities, "skipped": dict(info.skipped),
            "columns": list(info.columns)}


def describe_scene(path: str) -> dict:
    """A scene resolved and checked as replay will read it: every file it names is read with
    replay's readers (a bad one is an InputError, exit 3), each mesh placed as replay places it.

    Adds to ``Scene.describe``: the effects a replay of it runs (``replay.effects``); the terrain's
    kind and extent; the vehicle mesh's triangles, bounds in the vehicle frame and parts; per obstacle the up axis applied, its triangles,
    world bounds and whether they overlap the terrain's horizontal extent."""
    import numpy as np

    from tankcd_cli.collision.obstacles import placed_mesh, vehicle_mesh_triangles
    from tankcd_cli.scene import load_scene

    sc = load_scene(path)
    facts = sc.describe()
    # which effects a replay of it runs (the scene decides, not the user)
    facts["effects"] = {"turret_moving": effects_for(sc.vehicle, bool(sc.obstacles), True).as_dict(),
                        "turret_still": effects_for(sc.vehicle, bool(sc.obstacles), False).as_dict()}
    extent = None
    if sc.terrain_path:
        terrain = _scene_terrain(sc)
        facts["terrain"].update(terrain)
        extent = terrain["extent_x"], terrain["extent_y"]
    mesh = facts["vehicle"]["mesh"]
    if mesh is not None:
        tris, parts, names = vehicle_mesh_triangles(sc.vehicle_mesh, sc.vehicle_mesh_placement)
        pts = tris.reshape(-1, 3)
        mesh["triangles"] = int(len(tris))
        mesh["bounds"] = {"min": pts.min(axis=0).tolist(), "max": pts.max(axis=0).tolist()}
        mesh["parts"] = {name: int((parts == i).sum()) for i, name in enumerate(names)}
    for spec, ob in zip(sc.obstacles, facts["obstacles"]):
        raw, world = placed_mesh(spec)
        pts = world[np.unique(raw.faces)]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        ob["up_applied"] = getattr(raw, "up", None) or spec.up
        ob["triangles"] = int(len(raw.faces))
        ob["bounds"] = {"min": lo.tolist(), "max": hi.tolist()}
        ob["on_terrain"] = None if extent is None else bool(
            hi[0] >= extent[0][0] and lo[0] <= extent[0][1] and hi[1] >= extent[1][0] and lo[1] <= extent[1][1])
    return facts


def _scene_terrain(sc) -> dict:
    """The kind and extent of a scene's terrain, read as replay reads it (a store's attributes,
    a DEM's grid, a mesh's vertices)."""
    path = sc.terrain_path
    from tankcd_cli.io.h5 import is_hdf5

    if is_hdf5(path):
        d = describe_store(path)
        if d.get("kind") != "terrain store":
            raise InputError(path, f"is a {d.get('kind')}, not a terrain", where="[terrain] path")
        return {"kind": f"terrain store ({d['layout']} layout)", "crs": d.get("crs"),
                "extent_x": d["extent_x"], "extent_y": d["extent_y"], "extent_z": d["extent_z"]}
    from tankcd_cli.terrain.open import open_dem

    dem = open_dem(path)
    if dem is not None:
        with dem:
            g, i = dem.grid, dem.info
        x0, y0 = float(g.origin_x), float(g.origin_y)
        dx, dy = float(g.dx), float(g.dy)
        return {"kind": f"DEM ({i.format}, {g.rows} rows x {g.cols} columns of posts, classified on the fly)", "crs": g.crs_name,
                "extent_x": [x0, x0 + (g.cols - 1) * dx], "extent_y": [y0 - (g.rows - 1) * dy, y0]}
    from tankcd_cli.terrain.mesh.classify import read_mesh

    raw = read_mesh(path, up=sc.terrain_up)
    lo, hi = raw.vertices.min(axis=0), raw.vertices.max(axis=0)
    return {"kind": f"mesh ({raw.format}, {len(raw.faces):,} triangles, classified on the fly)",
            "up_applied": getattr(raw, "up", None) or sc.terrain_up_axis,
            "extent_x": [float(lo[0]), float(hi[0])], "extent_y": [float(lo[1]), float(hi[1])],
            "extent_z": [float(lo[2]), float(hi[2])]}
