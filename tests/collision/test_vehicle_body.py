"""The vehicle as moving parts: groups by name, placements against the barrel model, radii, articulated checks."""

import numpy as np
import pytest

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.collision.internal import barrel
from tankcd_cli.collision.obstacles import Obstacle, collide_obstacles
from tankcd_cli.collision.vehicle_body import group_of, group_placements, vehicle_body
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import PARTS, box, vehicle_mesh

T72 = vehicle_preset("t72")


def _body(vehicle=T72):
    tris, parts = vehicle_mesh(vehicle, 2)
    return vehicle_body(vehicle, tris, parts, PARTS)


def test_parts_turn_with_the_group_their_name_says():
    assert [group_of(n) for n in PARTS] == [0, 0, 0, 1, 2, 0, 0]
    assert [group_of(n) for n in ("Turret_main", "gun barrel", "Barrel", "mantlet", "GUN", " turret ")] == \
        [1, 2, 2, 0, 2, 1]
    body = _body()
    assert [g.name for g in body.groups] == ["hull", "turret", "gun"]
    assert body.part_names == PARTS
    gun = body.groups[2]
    assert set(PARTS[p] for p in gun.parts) == {"gun"}


def test_the_gun_group_goes_where_the_barrel_model_puts_the_barrel():
    body = _body()
    gun = body.groups[2]
    rng = np.random.default_rng(0)
    az = rng.uniform(-np.pi, np.pi, 30)
    el = np.radians(rng.uniform(T72.gun_min_deg, T72.gun_max_deg, 30))
    R = np.tile(np.eye(3), (30, 1, 1))
    Rg, tg = group_placements(body, gun, R, np.zeros((30, 3)), az, el)
    # the modelled barrel's axis at turret 0, gun 0 runs from the trunnion forward: its far end
    # turned by the placement is where internal.barrel puts the muzzle
    centre, axis, half, _ = barrel(T72, az, el)
    trunnion0 = np.array([T72.turret_x + T72.trunnion_forward, 0.0, T72.trunnion_height])
    muzzle0 = trunnion0 + [T72.gun_length, 0.0, 0.0]
    np.testing.assert_allclose(np.einsum("nij,j->ni", Rg, trunnion0) + tg, centre - half * axis, atol=1e-12)
    np.testing.assert_allclose(np.einsum("nij,j->ni", Rg, muzzle0) + tg, centre + half * axis, atol=1e-12)


def test_the_radii_bound_every_point_under_any_articulation():
    body = _body()
    rng = np.random.default_rng(1)
    pt = np.array(body.turret.point)
    pg = np.array(body.gun.point)
    for g in body.groups:
        pts = g.tree.triangles.reshape(-1, 3)
        for _ in range(20):
            az, el = rng.uniform(-np.pi, np.pi), rng.uniform(-0.5, 0.5)
            R, t = group_placements(body, g, np.eye(3)[None], np.zeros((1, 3)), np.array([az]), np.array([el]))
            moved = pts @ R[0].T + t[0]
            assert np.linalg.norm(moved, axis=1).max() <= g.radius + 1e-9
            if g.kind:
                assert np.hypot(moved[:, 0] - pt[0], moved[:, 1] - pt[1]).max() <= g.turret_radius + 1e-9
            if g.kind == 2:
                trunnion = R[0] @ pg + t[0]
                assert np.linalg.norm(moved - trunnion, axis=1).max() <= g.gun_radius + 1e-9


def _wall(lo, hi, name="wall"):
    tree = build_tree(box(lo, hi, 2), k=18)
    return Obstacle(name, tree, tree.lo[0, :3].copy(), tree.hi[0, :3].copy())


def test_a_gun_turned_toward_a_side_wall_hits_it_and_turned_away_does_not():
    body = _body()
    wall = _wall([-10.0, 4.0, 0.0], [10.0, 4.3, 3.0])  # 4 m to the left, along the hull
    R = np.tile(np.eye(3), (3, 1, 1))
    t = np.zeros((3, 3))
    turret = np.radians([90.0, 0.0, -90.0])
    hits = collide_obstacles(body, [wall], R, t, turret, np.zeros(3))
    assert hits.pose.tolist() == [0]  # turned left: the barrel reaches 6 m out
    assert body.part_names[hits.part[0]] == "gun"
    assert 4.0 - 1e-9 <= hits.point[0, 1] <= 4.3 + 1e-9  # where the barrel passes through the wall


def test_the_gun_forward_over_a_wall_ahead_and_the_drums_behind_cannot_both_be_hit():
    # the gun at 180 deg and -6 deg lies over the rear drums; a wall just ahead of the hull's
    # front is then out of the barrel's reach (the row that reported both was the gun left forward)
    body = _body()
    front = T72.hull_length / 2
    wall = _wall([front + 0.8, -3.0, 0.0], [front + 1.0, 3.0, 3.0])
    R = np.eye(3)[None]
    forward = collide_obstacles(body, [wall], R, np.zeros((1, 3)), np.radians([0.0]), np.radians([-6.0]))
    behind = collide_obstacles(body, [wall], R, np.zeros((1, 3)), np.radians([180.0]), np.radians([-6.0]))
    assert len(forward.pose) == 1 and body.part_names[forward.part[0]] == "gun"
    assert len(behind.pose) == 0
