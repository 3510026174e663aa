"""The vehicle against a scene's obstacles: trees (built or loaded from cache), broad phase, queries."""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from typing import Callable

import numpy as np

from tankcd_cli.bvh.build import Tree, build_tree
from tankcd_cli.bvh.query import collide
from tankcd_cli.bvh.store import read_tree, write_tree
from tankcd_cli.bvh.sweep import chain_placements, first_contacts, motion_rows, static_rows
from tankcd_cli.collision.vehicle_body import VehicleBody, group_placements, vehicle_body
from tankcd_cli.errors import InputError
from tankcd_cli.geometry.motion import rotation_angle
from tankcd_cli.geometry.pose import rotation_matrix
from tankcd_cli.io.atomic import atomic_path
from tankcd_cli.io.terrain_readers import RawTerrain, read_terrain
from tankcd_cli.scene import CollisionSettings, MeshPlacement, ObstacleSpec, Scene
from tankcd_cli.vehicle import Vehicle
from tankcd_cli.vehicle_mesh import PARTS, vehicle_mesh


@dataclass
class Obstacle:
    name: str
    tree: Tree
    lo: np.ndarray  # world AABB
    hi: np.ndarray


def read_mesh(path: str, up: str | None) -> RawTerrain:
    """A mesh read as replay reads it (``read_terrain``); ``up`` None is the format's convention."""
    return read_terrain(path, up=up)


def placement_matrix(scale, yaw_deg: float, pitch_deg: float, roll_deg: float) -> np.ndarray:
    """M (3, 3) with M @ p = R(yaw, pitch, roll) @ (scale * p), R = Rz(yaw) Ry(pitch) Rx(roll)."""
    R = rotation_matrix(np.radians(roll_deg), np.radians(pitch_deg), np.radians(yaw_deg))
    return R * np.asarray(scale, dtype=float)[None, :]


def place(vertices: np.ndarray, scale, yaw_deg: float, pitch_deg: float, roll_deg: float,
          position=(0.0, 0.0, 0.0)) -> np.ndarray:
    """position + R @ (scale * p) for every row p of ``vertices`` (n, 3)."""
    M = placement_matrix(scale, yaw_deg, pitch_deg, roll_deg)
    return vertices @ M.T + np.asarray(position, dtype=float)


def placed_mesh(spec: ObstacleSpec):
    """An obstacle's mesh as read (RawTerrain) and its vertices (n, 3) in the world."""
    raw = read_mesh(spec.path, spec.up)
    return raw, place(raw.vertices, spec.scale, spec.yaw_deg, spec.pitch_deg, spec.roll_deg, spec.position)


def placed_triangles(spec: ObstacleSpec) -> tuple[np.ndarray, str]:
    """An obstacle's triangles (m, 3, 3) in the world, and its mesh's SHA-256."""
    raw, world = placed_mesh(spec)
    return world[raw.faces], raw.sha256


def _cache_key(spec: ObstacleSpec, sha: str, settings: CollisionSettings, up: str | None = None) -> str:
    """What a cached tree depends on: the mesh, the up axis it was read with (``up``: the one
    applied, so a change of the format's convention is seen), the placement and the settings."""
    text = json.dumps({"sha256": sha, **spec.placement(), "up": up or spec.up,
                       "k": settings.k, "aabb_levels": settings.aabb_levels, "split": settings.split,
                       "leaf_size": settings.leaf_size}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def cache_path(scene: Scene, spec: ObstacleSpec) -> str:
    safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in spec.name)
    return os.path.join(os.path.dirname(os.path.abspath(scene.path)), ".tankcd-cache", f"{safe}.bvh.h5")


def load_obstacles(scene: Scene, cache: bool = True, rebuild: bool = False,
                   progress: Callable[[str], None] | None = None) -> list[Obstacle]:
    """Every obstacle's world tree: from the scene's cache when it is up to date (same mesh
    SHA-256, placement and build settings), else built (and cached when ``cache``)."""
    say = progress or (lambda s: None)
    out = []
    for spec in scene.obstacles:
        raw, world = placed_mesh(spec)
        tris, sha = world[raw.faces], raw.sha256
        key = _cache_key(spec, sha, scene.collision, getattr(raw, "up", None))
        path = cache_path(scene, spec)
        tree = None
        if not rebuild and os.path.exists(path):
            try:
                cached, _ = read_tree(path)
                if cached.attrs.get("cache_key") == key:
                    tree = cached
                    say(f"tree of {spec.name}: cached {path}")
                else:
                    say(f"tree of {spec.name}: cache is stale (mesh, placement or settings changed): rebuilding")
            except InputError:
                say(f"tree of {spec.name}: cache unreadable: rebuilding")
        if tree is None:
            c = scene.collision
            tree = build_tree(tris, k=c.k, leaf_size=c.leaf_size, aabb_levels=c.aabb_levels, split=c.split)
            tree.attrs.update({"source": spec.path, "source_sha256": sha, "cache_key": key,
                               "placement": json.dumps({**spec.placement(),
                                                        "up": getattr(raw, "up", None) or spec.up})})
            say(f"tree of {spec.name}: built ({len(tris):,} triangles, {tree.nodes:,} nodes)")
            if cache:
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with atomic_path(path, ".h5") as tmp:
                    write_tree(tmp, tree)
        out.append(Obstacle(spec.name, tree, tree.lo[0, :3].copy(), tree.hi[0, :3].copy()))
    return out


def scene_vehicle_body(scene: Scene, detail: int = 2) -> VehicleBody:
    """The scene's vehicle as moving parts (``collision.vehicle_body``): its mesh brought into the
    vehicle frame by its placement (scale, then rotation), its parts the file's (OBJ objects or
    groups, glTF nodes) when it has them, else one part, "vehicle"; without a mesh, the one
    generated from the dimensions, whose turret and gun turn."""
    return body_of(scene.vehicle, scene.vehicle_mesh, scene.vehicle_mesh_placement, scene.collision, detail)


def body_of(vehicle: Vehicle, mesh: str | None, placement: MeshPlacement,
            settings: CollisionSettings = CollisionSettings(), detail: int = 2) -> VehicleBody:
    """A vehicle as moving parts: its mesh file (None: the shape generated from its dimensions)
    brought into the vehicle frame by ``placement`` (``scene.MeshPlacement``), trees built with
    ``settings`` (the scene's [collision])."""
    if mesh:
        tris, parts, names = vehicle_mesh_triangles(mesh, placement)
    else:
        tris, parts = vehicle_mesh(vehicle, detail)
        names = PARTS
    return vehicle_body(vehicle, tris, parts, names, k=settings.k, leaf_size=settings.leaf_size,
                        aabb_levels=settings.aabb_levels, split=settings.split)


def vehicle_mesh_triangles(mesh: str, placement: MeshPlacement):
    """A vehicle mesh file: triangles (m, 3, 3) in the vehicle frame (``placement`` applied), part ids
    (m,) and names."""
    raw = read_mesh(mesh, placement.up)
    tris = place(raw.vertices, placement.scale, placement.yaw_deg, placement.pitch_deg, placement.roll_deg)[raw.faces]
    parts, names = file_parts(raw)
    return tris, parts, names


def file_parts(raw) -> tuple[np.ndarray, tuple]:
    """Per-face part ids (m,) and part names from a mesh file's objects/groups/nodes; faces in
    none of them (or a file without parts) belong to a part named "vehicle"."""
    m = len(raw.faces)
    face_part = getattr(raw, "face_part", None)
    names = tuple(str(n) for n in getattr(raw, "part_names", ()) or ())
    if face_part is None or not names:
        return np.zeros(m, dtype=np.int32), ("vehicle",)
    ids = np.asarray(face_part).astype(np.int64).ravel()
    if len(ids) != m:
        return np.zeros(m, dtype=np.int32), ("vehicle",)
    names = tuple(n or f"part{i + 1}" for i, n in enumerate(names))
    loose = (ids < 0) | (ids >= len(names))
    if loose.any():
        ids = np.where(loose, len(names), ids)
        names = names + ("vehicle",)
    return ids.astype(np.int32), names


@dataclass
class ObstacleHits:
    """One row per (pose, obstacle, vehicle part) in contact, ordered by pose, obstacle and part:
    pose index, obstacle index, vehicle part, a contact point, the triangle contacts found."""

    pose: np.ndarray
    obstacle: np.ndarray
    part: np.ndarray
    point: np.ndarray
    contacts: np.ndarray
    node_tests: int
    tri_tests: int
    broad_pairs: int


def collide_obstacles(body: VehicleBody, obstacles: list[Obstacle], rotation: np.ndarray, translation: np.ndarray,
                      turret_rad=0.0, gun_rad=0.0, all_contacts: bool = False) -> ObstacleHits:
    """The vehicle at N poses (hull rotation (N, 3, 3), translation (N, 3), turret and gun angles
    (N,) rad) against every obstacle: broad phase on world AABBs per part, then the tandem tree
    walk for the pairs that remain. One row per (pose, obstacle, part) in contact (each part's
    own tree, ``BodyGroup.part_trees``: a part is in contact exactly when a triangle of it
    intersects one of the obstacle's), ``contacts`` the triangle contacts found for that part
    (one unless ``all_contacts``)."""
    n = len(rotation)
    if not obstacles or n == 0:
        empty = np.zeros(0, dtype=np.int64)
        return ObstacleHits(empty, empty, empty, np.zeros((0, 3)), empty, 0, 0, 0)
    turret_rad = np.broadcast_to(np.asarray(turret_rad, dtype=float), (n,))
    gun_rad = np.broadcast_to(np.asarray(gun_rad, dtype=float), (n,))
    point = {}  # (pose, obstacle, part) -> point; counts beside
    count: dict = {}
    node_tests = tri_tests = broad = 0
    # first the box no point of the vehicle leaves under any articulation: its radius about the origin
    translation = np.asarray(translation, dtype=float)
    reach = body.radius * (1 + 1e-9)
    close = np.zeros(n, dtype=bool)
    for ob in obstacles:
        close |= ((translation - reach <= ob.hi) & (translation + reach >= ob.lo)).all(axis=1)
    sel = np.flatnonzero(close)
    if len(sel) == 0:
        empty = np.zeros(0, dtype=np.int64)
        return ObstacleHits(empty, empty, empty, np.zeros((0, 3)), empty, 0, 0, 0)
    for group in body.groups:
        R, t = group_placements(body, group, np.asarray(rotation)[sel], translation[sel], turret_rad[sel],
                                gun_rad[sel])
        for part, tree in group.part_trees:
            # the part's world AABB at each pose: its root box moved (centre R c + t, half-widths |R| h)
            centre = 0.5 * (tree.lo[0, :3] + tree.hi[0, :3])
            half = 0.5 * (tree.hi[0, :3] - tree.lo[0, :3])
            world_centre = R @ centre + t
            world_half = np.abs(R) @ half
            lo, hi = world_centre - world_half, world_centre + world_half
            for j, ob in enumerate(obstacles):
                near = np.flatnonzero(((lo <= ob.hi) & (hi >= ob.lo)).all(axis=1))
                broad += len(near)
                if len(near) == 0:
                    continue
                res = collide(tree, ob.tree, R[near], t[near], all_contacts=all_contacts)
                node_tests += int(res.node_tests.sum())
                tri_tests += int(res.tri_tests.sum())
                for k in np.flatnonzero(res.found > 0):
                    key = (int(sel[near[k]]), j, part)
                    point[key] = res.points[k, 0]
                    count[key] = int(res.found[k])
    keys = sorted(point)
    pose = np.array([k[0] for k in keys], dtype=np.int64)
    obstacle = np.array([k[1] for k in keys], dtype=np.int64)
    return ObstacleHits(pose, obstacle, np.array([k[2] for k in keys], dtype=np.int64),
                        np.array([point[k] for k in keys], dtype=float).reshape(-1, 3),
                        np.array([count[k] for k in keys], dtype=np.int64), node_tests, tri_tests, broad)


@dataclass
class SweptHits:
    """One row per (step, obstacle, vehicle part) whose first contact lies in the step, ordered by
    step, obstacle and part: step index, obstacle index, vehicle part, the fraction s of the step
    at that part's first contact with the obstacle, the world contact point."""

    step: np.ndarray
    obstacle: np.ndarray
    part: np.ndarray
    s: np.ndarray
    point: np.ndarray
    queries: int  # part-obstacle pairs walked along their steps (the rest cost one box test)


def obstacles_along(body: VehicleBody, obstacles: list[Obstacle], q0: np.ndarray, c0: np.ndarray, q1: np.ndarray,
                    c1: np.ndarray, turret0, dturret, gun0, dgun, known: np.ndarray | None = None) -> SweptHits:
    """The first contact of each vehicle part with each obstacle over M rigid steps of the hull,
    from attitude q0 (M, 4) and origin c0 (M, 3) to q1, c1, the turret and gun turning from
    turret0, gun0 by dturret, dgun (M,) rad at constant rates (``geometry.motion``; ``bvh.sweep``
    for the method and its guarantees), each part by its own tree (``BodyGroup.part_trees``)
    under its group's motion bound (a part's points are among the group's).

    Broad phase: first a box around the whole step (the hull origin's two places grown by the
    vehicle's radius, which no point of it passes under any articulation), then per part and
    obstacle the part's world box at the step's middle grown by half its group's motion bound,
    which holds it throughout the step (every point stays within half the bound of where it is
    at the middle); a step whose boxes miss every obstacle's costs those box tests alone.

    known : (M, obstacles) bool, optional: pairs of step and obstacle whose contact is known at the
    step's start (the vehicle there touches the obstacle); they are not walked, and give no row."""
    m = len(q0)
    nparts = len(body.part_names)
    queries = 0
    if m == 0 or not obstacles:
        return _swept_hits(np.zeros(0, np.int64), np.full((0, len(obstacles), nparts), np.inf),
                           np.zeros((0, len(obstacles), nparts, 3)), queries)
    c0, c1 = np.asarray(c0, float), np.asarray(c1, float)
    reach = body.radius * (1 + 1e-9)
    lo = np.minimum(c0, c1) - reach
    hi = np.maximum(c0, c1) + reach
    close = np.zeros(m, dtype=bool)
    for ob in obstacles:
        close |= ((lo <= ob.hi) & (hi >= ob.lo)).all(axis=1)
    idx = np.flatnonzero(close)
    # per close step, obstacle and part: the earliest contact found and its point
    best_s = np.full((len(idx), len(obstacles), nparts), np.inf)
    best_point = np.full((len(idx), len(obstacles), nparts, 3), np.nan)
    if len(idx) == 0:
        return _swept_hits(idx, best_s, best_point, queries)
    q0, q1, c0, c1 = np.asarray(q0, float)[idx], np.asarray(q1, float)[idx], c0[idx], c1[idx]
    angles = (np.asarray(turret0, float)[idx], np.asarray(gun0, float)[idx])
    changes = (np.asarray(dturret, float)[idx], np.asarray(dgun, float)[idx])
    theta = rotation_angle(q0, q1)
    travel = np.linalg.norm(c1 - c0, axis=1)
    half_s = np.full(len(idx), 0.5)
    for group in body.groups:
        joints = body.joints(group.kind)
        rows, njoints = motion_rows(q0, c0, q1, c1, joints, angles[:group.kind], changes[:group.kind])
        rate = group.bound_rate(travel, theta, changes[0], changes[1])
        R, t = chain_placements(rows, njoints, half_s)
        for part, tree in group.part_trees:
            centre = 0.5 * (tree.lo[0, :3] + tree.hi[0, :3])
            half = 0.5 * (tree.hi[0, :3] - tree.lo[0, :3])
            world_centre = np.einsum("nij,j->ni", R, centre) + t
            world_half = np.einsum("nij,j->ni", np.abs(R), half) + 0.5 * rate[:, None]
            lo, hi = world_centre - world_half, world_centre + world_half
            for j, ob in enumerate(obstacles):
                near = ((lo <= ob.hi) & (hi >= ob.lo)).all(axis=1)
                if known is not None:
                    near &= ~known[idx, j]
                near = np.flatnonzero(near)
                if len(near) == 0:
                    continue
                queries += len(near)
                still, none = static_rows(len(near))
                got = first_contacts(tree, ob.tree, rows[near], njoints[near], still, none, rate[near])
                hit = np.flatnonzero(got.found)
                k = near[hit]
                better = got.s[hit] < best_s[k, j, part]
                k, h = k[better], hit[better]
                best_s[k, j, part] = got.s[h]
                best_point[k, j, part] = got.points[h]
    return _swept_hits(idx, best_s, best_point, queries)


def _swept_hits(idx, best_s, best_point, queries) -> SweptHits:
    row, obstacle, part = np.nonzero(np.isfinite(best_s))
    return SweptHits(idx[row], obstacle, part, best_s[row, obstacle, part], best_point[row, obstacle, part], queries)
