"""Collision queries between a moving tree and a static one, as plain arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.bvh.build import Tree
from tankcd_cli.bvh.traverse import ALL, FIRST, brute_force_batch, collide_batch
from tankcd_cli.geometry import kdop


@dataclass
class Contacts:
    """Per pose: contacts found (N,), the first pairs (N, c, 2) of input triangle indices
    (moving, static; -1 unused) and contact points (N, c, 3) in the world, node-pair and
    triangle-pair tests (N,)."""

    found: np.ndarray
    pairs: np.ndarray
    points: np.ndarray
    node_tests: np.ndarray
    tri_tests: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return self.found > 0


def collide(moving: Tree, static: Tree, rotation: np.ndarray, translation: np.ndarray, all_contacts: bool = False,
            max_contacts: int = 16) -> Contacts:
    """Test ``moving`` placed by x -> R x + t at each pose against ``static``.

    rotation : (N, 3, 3); translation : (N, 3), m
    all_contacts : every intersecting triangle pair (else stop at the first)
    """
    if moving.k != static.k:
        raise ValueError(f"both trees need the same k-DOP type (got k = {moving.k} and {static.k})")
    d = kdop.directions(moving.k)
    W = kdop.triple_inverses(moving.k)
    R = np.ascontiguousarray(np.asarray(rotation, dtype=float).reshape(-1, 3, 3))
    t = np.ascontiguousarray(np.asarray(translation, dtype=float).reshape(-1, 3))
    # poses differ a lot in cost (a clear pose ends at the roots, a grazing one goes deep): the
    # compiled kernel hands them to the threads in small chunks (POSE_CHUNK, OpenMP dynamic schedule)
    found, pairs, points, node_tests, tri_tests = collide_batch(
        R, t, d, W, moving, static, ALL if all_contacts else FIRST, max_contacts)
    return Contacts(found, pairs, points, node_tests, tri_tests)


def collide_brute_force(moving_triangles: np.ndarray, static_triangles: np.ndarray, rotation, translation,
                        all_contacts: bool = False) -> np.ndarray:
    """Contacts per pose from every triangle pair (the oracle): (N,) counts."""
    R = np.ascontiguousarray(np.asarray(rotation, dtype=float).reshape(-1, 3, 3))
    t = np.ascontiguousarray(np.asarray(translation, dtype=float).reshape(-1, 3))
    return brute_force_batch(R, t, np.ascontiguousarray(moving_triangles, dtype=float),
                             np.ascontiguousarray(static_triangles, dtype=float), ALL if all_contacts else FIRST)
