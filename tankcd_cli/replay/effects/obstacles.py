"""The vehicle against the scene's obstacles (``obstacle``): at the rows (broad phase on world boxes
first), and exact along each rigid sub-step of the motion between rows
(``collision.obstacles.obstacles_along``: never missed, a pass within 1 mm may count, the time to
0.5 mm of travel).

For obstacles a stretch of motion starts in contact when the vehicle touches the obstacle there or
touched it during the stretch before (a post that passes wholly inside the hull's shell touches no
triangle for a while: it is still one contact, not a new one where it leaves). Within one stretch
that starts in contact, a separation and a new contact of the same pair before the next sub-step is
not reported apart (it is the same episode at the resolution used)."""

from __future__ import annotations

import numpy as np

from tankcd_cli.bvh.sweep import LEAF_BOUND
from tankcd_cli.collision.obstacles import collide_obstacles, obstacles_along
from tankcd_cli.matching.match import OFF
from tankcd_cli.replay.effects.effect import Effect, Event, EventKind, Run
from tankcd_cli.vehicle import Vehicle


class Obstacles(Effect):
    """The vehicle's parts against the obstacles: run only when the scene has obstacles."""

    name = "obstacles"
    flag = "obstacles"
    kinds = (EventKind("obstacle", True, "X", "#b71c1c", "hit an obstacle"),)
    stage = 1

    def runs(self, vehicle: Vehicle, obstacles: bool, turret_moves: bool) -> bool:
        return bool(obstacles)

    def resolution(self, surface) -> dict:
        """The sweep's pass and time bounds, m."""
        return {"obstacle_pass_m": 2 * LEAF_BOUND, "obstacle_time_travel_m": LEAF_BOUND}

    def no_contacts(self, run: Run, n: int) -> np.ndarray:
        return np.zeros((n, len(run.obstacles)), dtype=bool)

    def at_rows(self, run: Run, kind, chunk, poses, good, where) -> tuple[list, np.ndarray]:
        """An event per row, obstacle and part in contact; contacts (N, obstacles)."""
        contact = self.no_contacts(run, len(chunk))
        if not len(good):
            return [], contact
        body = kind.body
        hits = collide_obstacles(body, run.obstacles, poses.rotation[good], poses.position[good],
                                 np.radians(chunk.turret_deg[good]), np.radians(chunk.gun_deg[good]))
        codes = chunk.entity if chunk.entity is not None else np.zeros(len(chunk), dtype=np.int64)
        events = [Event(int(chunk.step[good[p]]), float(chunk.t[good[p]]), "obstacle", body.part_names[part],
                        run.obstacles[o].name, {"point": [round(float(c), 4) for c in point], "contacts": int(n)},
                        int(codes[good[p]]))
                  for p, o, part, point, n in zip(hits.pose, hits.obstacle, hits.part, hits.point, hits.contacts)]
        names = {ob.name: j for j, ob in enumerate(run.obstacles)}
        for e in events:
            contact[where[e.step], names[e.b]] = True
        return events, contact

    def along(self, run: Run, kind, block) -> tuple[list, np.ndarray | None]:
        """Every rigid sub-step of every interval against the obstacles; an event per (sub-step,
        obstacle) where a contact begins (the sub-step's start not already touching that obstacle);
        and per row (N, obstacles) whether the stretch of motion ending there touched each."""
        if not run.obstacles:
            return [], None
        rows, iv, a, b, at, sub, segments = block.rows, block.iv, block.a, block.b, block.at, block.sub, block.segments
        body, obstacles = kind.body, run.obstacles
        k = len(obstacles)
        nrows = len(rows)
        swept_into = np.zeros((nrows, k), dtype=bool)
        # the sub-steps' own contacts (the rows' are known), for the state at each segment's start
        sub_touch = np.zeros((len(sub), k), dtype=bool)
        ok_sub = np.flatnonzero(sub.status != OFF)
        if len(ok_sub):
            hits = collide_obstacles(body, obstacles, sub.rotation[ok_sub], sub.position[ok_sub],
                                     np.radians(at["turret_deg"][ok_sub]), np.radians(at["gun_deg"][ok_sub]))
            sub_touch[ok_sub[hits.pose], hits.obstacle] = True
        seg_iv, seg_k, f0, f1 = segments["seg_iv"], segments["seg_k"], segments["f0"], segments["f1"]
        touch0 = np.concatenate([rows.contacts[self.name], sub_touch])[segments["start"]]
        use = np.flatnonzero(segments["use"])
        if len(use) == 0:
            return [], swept_into
        i = seg_iv[use]
        turret0 = np.radians(iv.turret0[i] + f0[use] * iv.dturret[i])
        gun0 = np.radians(iv.gun0[i] + f0[use] * iv.dgun[i])
        dturret = np.radians((f1[use] - f0[use]) * iv.dturret[i])
        dgun = np.radians((f1[use] - f0[use]) * iv.dgun[i])
        # a segment that starts touching an obstacle touched it, and a contact with it there continues
        # (no event): the sweep, which would find it at the start, is spared for that pair
        start_touch = touch0[use]
        swept = obstacles_along(body, obstacles, segments["q0"][use], segments["c0"][use], segments["q1"][use],
                                segments["c1"][use], turret0, dturret, gun0, dgun, known=start_touch)
        touched = np.zeros((len(seg_iv), k), dtype=bool)
        touched[use] = start_touch
        touched[use[swept.step], swept.obstacle] = True
        # a segment continues the one before it where that one ends at its start: within an interval,
        # or from the last of the interval before when it ends at this interval's first row
        follows = np.zeros(len(seg_iv), dtype=bool)
        follows[1:] = (seg_k[1:] > 0) | (a[seg_iv[1:]] == b[seg_iv[:-1]])
        touch0[1:] |= touched[:-1] & follows[1:, None]
        last_of_interval = np.flatnonzero(np.append(seg_iv[1:] != seg_iv[:-1], True))
        swept_into[b[seg_iv[last_of_interval]]] = touched[last_of_interval]
        events = []
        for seg, o, part, s, point in zip(swept.step, swept.obstacle, swept.part, swept.s, swept.point):
            g = use[seg]
            if touch0[g, o]:
                continue  # a contact continuing from the segment's start
            ivx = seg_iv[g]
            frac_at = f0[g] + s * (f1[g] - f0[g])
            t = float(iv.t0[ivx] + frac_at * iv.dt[ivx])
            t = min(max(t, float(np.nextafter(iv.t0[ivx], np.inf))), float(iv.t0[ivx] + iv.dt[ivx]))
            events.append(Event(int(rows.step[a[ivx]]), t, "obstacle", body.part_names[part], obstacles[o].name,
                                {"point": [round(float(c), 4) for c in point], "between": True},
                                int(rows.entity[a[ivx]])))
        return events, swept_into


OBSTACLES = Obstacles()
