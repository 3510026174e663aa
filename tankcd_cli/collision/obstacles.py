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
from tankcd_cli.errors import InputError
from tankcd_cli.replay.scene import CollisionSettings, ObstacleSpec, Scene
from tankcd_cli.vehicle_mesh import PARTS, vehicle_mesh


@dataclass
class Obstacle:
    name: str
    tree: Tree
    lo: np.ndarray  # world AABB
    hi: np.ndarray


def placed_triangles(spec: ObstacleSpec) -> tuple[np.ndarray, str]:
    """An obstacle's triangles (m, 3, 3) in the world, and its mesh's SHA-256."""
    from tankcd_cli.io.terrain_readers import read_terrain

    raw = read_terrain(spec.path, up=spec.up)
    a = np.radians(spec.yaw_deg)
    R = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    world = raw.vertices @ R.T + np.asarray(spec.position)
    return world[raw.faces], raw.sha256


def _cache_key(spec: ObstacleSpec, sha: str, settings: CollisionSettings) -> str:
    text = json.dumps({"sha256": sha, "up": spec.up, "position": spec.position, "yaw_deg": spec.yaw_deg,
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
    from tankcd_cli.io.atomic import atomic_path

    say = progress or (lambda s: None)
    out = []
    for spec in scene.obstacles:
        tris, sha = placed_triangles(spec)
        key = _cache_key(spec, sha, scene.collision)
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
                               "placement": json.dumps({"up": spec.up, "position": spec.position,
                                                        "yaw_deg": spec.yaw_deg})})
            say(f"tree of {spec.name}: built ({len(tris):,} triangles, {tree.nodes:,} nodes)")
            if cache:
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with atomic_path(path, ".h5") as tmp:
                    write_tree(tmp, tree)
        out.append(Obstacle(spec.name, tree, tree.lo[0, :3].copy(), tree.hi[0, :3].copy()))
    return out


def vehicle_tree(scene: Scene, detail: int = 2) -> tuple[Tree, np.ndarray, tuple]:
    """The vehicle's tree in its own frame, its triangles' part labels and the part names."""
    c = scene.collision
    if scene.vehicle_mesh:
        from tankcd_cli.io.terrain_readers import read_terrain

        raw = read_terrain(scene.vehicle_mesh, up=scene.vehicle_mesh_up)
        tris = raw.vertices[raw.faces]
        parts, names = np.zeros(len(tris), dtype=np.uint8), ("vehicle",)
    else:
        tris, parts = vehicle_mesh(scene.vehicle, detail)
        names = PARTS
    tree = build_tree(tris, k=c.k, leaf_size=c.leaf_size, aabb_levels=c.aabb_levels, split=c.split)
    return tree, parts, names


@dataclass
class ObstacleHits:
    """One row per (pose, obstacle) in contact: pose index, obstacle index, vehicle part, point, contacts."""

    pose: np.ndarray
    obstacle: np.ndarray
    part: np.ndarray
    point: np.ndarray
    contacts: np.ndarray
    node_tests: int
    tri_tests: int
    broad_pairs: int


def collide_obstacles(moving: Tree, parts: np.ndarray, obstacles: list[Obstacle], rotation: np.ndarray,
                      translation: np.ndarray, all_contacts: bool = False) -> ObstacleHits:
    """Broad phase on world AABBs, then the tandem tree walk for the pairs that remain."""
    n = len(rotation)
    if not obstacles or n == 0:
        empty = np.zeros(0, dtype=np.int64)
        return ObstacleHits(empty, empty, empty, np.zeros((0, 3)), empty, 0, 0, 0)
    # the vehicle's world AABB at each pose: its root box moved (centre R c + t, half-widths |R| h)
    centre = 0.5 * (moving.lo[0, :3] + moving.hi[0, :3])
    half = 0.5 * (moving.hi[0, :3] - moving.lo[0, :3])
    world_centre = rotation @ centre + translation
    world_half = np.abs(rotation) @ half
    lo, hi = world_centre - world_half, world_centre + world_half
    rows = {k: [] for k in ("pose", "obstacle", "part", "point", "contacts")}
    node_tests = tri_tests = broad = 0
    for j, ob in enumerate(obstacles):
        near = np.flatnonzero(((lo <= ob.hi) & (hi >= ob.lo)).all(axis=1))
        broad += len(near)
        if len(near) == 0:
            continue
        res = collide(moving, ob.tree, rotation[near], translation[near], all_contacts=all_contacts)
        node_tests += int(res.node_tests.sum())
        tri_tests += int(res.tri_tests.sum())
        hit = np.flatnonzero(res.found > 0)
        rows["pose"].append(near[hit])
        rows["obstacle"].append(np.full(len(hit), j))
        rows["part"].append(parts[res.pairs[hit, 0, 0]])
        rows["point"].append(res.points[hit, 0])
        rows["contacts"].append(res.found[hit])
    cat = {k: (np.concatenate(v) if v else np.zeros((0, 3) if k == "point" else 0, dtype=float if k == "point" else np.int64))
           for k, v in rows.items()}
    order = np.lexsort((cat["obstacle"], cat["pose"]))
    return ObstacleHits(cat["pose"][order], cat["obstacle"][order], cat["part"][order], cat["point"][order],
                        cat["contacts"][order], node_tests, tri_tests, broad)
