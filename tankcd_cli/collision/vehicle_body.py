"""The vehicle as moving parts: the hull and what is fixed to it, the turret, the gun.

A vehicle mesh (the scene's, or the one generated from the dimensions) is modelled with the turret
at azimuth 0 and the gun at elevation 0, in the vehicle frame. Its parts fall into three rigid
groups by name (docs/formats.md, "Vehicle mesh"): parts named ``turret...`` turn with the turret,
parts named ``gun...`` or ``barrel...`` turn with the gun, everything else is fixed to the hull
(case does not matter). The turret turns by ``turret_deg`` about the vertical axis through the
turret ring centre (``turret_x`` ahead of the footprint centre); the gun turns by ``gun_deg``
about the trunnion axis (across the turret, ``trunnion_forward`` ahead of the ring centre at
``trunnion_height``), positive raising the muzzle, as ``collision.internal`` models the barrel.

Each group carries its own tree in the vehicle frame, the part of each of its triangles, and the
radii the motion bound of ``geometry.motion`` needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from tankcd_cli.bvh.build import Tree, build_tree
from tankcd_cli.bvh.sweep import Joint
from tankcd_cli.geometry.motion import axis_rotation
from tankcd_cli.vehicle import Vehicle

GROUPS = ("hull", "turret", "gun")


def group_of(part_name: str) -> int:
    """0 hull, 1 turret, 2 gun: which rigid group a part of this name turns with."""
    name = part_name.strip().lower()
    if name.startswith("turret"):
        return 1
    if name.startswith(("gun", "barrel")):
        return 2
    return 0


@dataclass(frozen=True)
class BodyGroup:
    """One rigid group of the vehicle.

    kind : 0 hull, 1 turret, 2 gun (the joints it turns with: kind of them)
    tree : its triangles in the vehicle frame (turret 0, gun 0)
    parts : (m,) the part (index into ``VehicleBody.part_names``) of each of the tree's input triangles
    radius : m, the farthest any of its points gets from the hull origin under any articulation
    turret_radius : m, the farthest any of its points is from the turret axis (0 for the hull group)
    gun_radius : m, the farthest any of its points is from the trunnion (gun group only, else 0)
    """

    kind: int
    tree: Tree
    parts: np.ndarray
    radius: float
    turret_radius: float
    gun_radius: float

    @property
    def name(self) -> str:
        return GROUPS[self.kind]

    @cached_property
    def part_trees(self) -> tuple:
        """((part, tree), ...): a tree of each of the group's parts' triangles (built with the group
        tree's settings when first asked: obstacle queries name every part in contact, not the first
        found), the group's own tree where it has one part. Source indices of a part's tree index
        its own triangles."""
        parts = self.parts[self.tree.source_index]  # the part of each triangle in leaf order
        ids = np.unique(parts)
        if len(ids) == 1:
            return ((int(ids[0]), self.tree),)
        t = self.tree
        return tuple((int(p), build_tree(t.triangles[parts == p], k=t.k, leaf_size=t.leaf_size,
                                         aabb_levels=t.aabb_levels, split=t.split)) for p in ids)

    def bound_rate(self, travel, turn, dturret, dgun) -> np.ndarray:
        """How far any point of the group moves per unit of a rigid step's fraction, at most (m):
        travel (m) plus turn (rad) times ``radius``, plus the turret's and the gun's changes
        (rad) times their radii, absolute values summed (``geometry.motion``'s bound), grown by
        a relative 1e-9 for the bound's own rounding."""
        rate = (np.abs(travel) + np.abs(turn) * self.radius + np.abs(dturret) * self.turret_radius
                + np.abs(dgun) * self.gun_radius)
        return rate * (1 + 1e-9) + 1e-12


@dataclass(frozen=True)
class VehicleBody:
    """The vehicle's groups (those with triangles, hull first), its part names and its two joints."""

    groups: tuple
    part_names: tuple
    turret: Joint
    gun: Joint

    @property
    def radius(self) -> float:
        return max(g.radius for g in self.groups)

    def joints(self, kind: int) -> tuple:
        return (self.turret, self.gun)[:kind]


def joints_of(vehicle: Vehicle) -> tuple[Joint, Joint]:
    """The turret joint (about +z through the ring centre) and the gun joint (about -y through the
    trunnion, so a positive angle raises the muzzle), in the vehicle frame at turret 0."""
    turret = Joint((vehicle.turret_x, 0.0, 0.0), (0.0, 0.0, 1.0))
    gun = Joint((vehicle.turret_x + vehicle.trunnion_forward, 0.0, vehicle.trunnion_height), (0.0, -1.0, 0.0))
    return turret, gun


def vehicle_body(vehicle: Vehicle, triangles: np.ndarray, parts: np.ndarray, part_names: tuple, k: int = 18,
                 leaf_size: int = 4, aabb_levels: int = 2, split: str = "sah") -> VehicleBody:
    """The body of a vehicle mesh: triangles (m, 3, 3) in the vehicle frame, their part ids (m,)
    into ``part_names``; trees built with the given settings."""
    triangles = np.asarray(triangles, dtype=float)
    parts = np.asarray(parts, dtype=np.int64)
    kind_of_part = np.array([group_of(n) for n in part_names], dtype=np.int64)
    kind = kind_of_part[parts]
    turret, gun = joints_of(vehicle)
    pt = np.array(turret.point)
    pg = np.array(gun.point)
    groups = []
    for g in range(3):
        idx = np.flatnonzero(kind == g)
        if len(idx) == 0:
            continue
        tris = triangles[idx]
        pts = tris.reshape(-1, 3)
        from_turret = np.hypot(pts[:, 0] - pt[0], pts[:, 1] - pt[1]).max()  # the turret axis is vertical
        if g == 0:
            radius, turret_radius, gun_radius = np.linalg.norm(pts, axis=1).max(), 0.0, 0.0
        elif g == 1:
            # turned about the axis, a point keeps its height and its distance from the axis
            radius = np.hypot(np.hypot(pt[0], pt[1]) + from_turret, np.abs(pts[:, 2]).max())
            turret_radius, gun_radius = from_turret, 0.0
        else:
            gun_radius = np.linalg.norm(pts - pg, axis=1).max()
            turret_radius = np.hypot(pg[0] - pt[0], pg[1] - pt[1]) + gun_radius
            radius = np.linalg.norm(pt) + np.linalg.norm(pg - pt) + gun_radius
        tree = build_tree(tris, k=k, leaf_size=leaf_size, aabb_levels=aabb_levels, split=split)
        groups.append(BodyGroup(g, tree, parts[idx], float(radius), float(turret_radius), float(gun_radius)))
    return VehicleBody(tuple(groups), tuple(part_names), turret, gun)


def group_placements(body: VehicleBody, group: BodyGroup, rotation: np.ndarray, translation: np.ndarray,
                     turret_rad: np.ndarray, gun_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a group is at N poses: (R (N, 3, 3), t (N, 3)) with world = R p + t for its points p,
    the hull at (rotation (N, 3, 3), translation (N, 3)) and the turret and gun at their angles (N,) rad."""
    R = np.asarray(rotation, dtype=float)
    t = np.asarray(translation, dtype=float)
    if group.kind == 0:
        return R, t
    n = len(R)
    A = np.tile(np.eye(3), (n, 1, 1))
    b = np.zeros((n, 3))
    for joint, angle in list(zip(body.joints(group.kind), (turret_rad, gun_rad)))[::-1]:  # the gun turns first
        J = axis_rotation(joint.axis, np.broadcast_to(angle, (n,)))
        p = np.array(joint.point)
        A, b = J @ A, np.einsum("nij,nj->ni", J, b - p) + p
    return R @ A, np.einsum("nij,nj->ni", R, b) + t
