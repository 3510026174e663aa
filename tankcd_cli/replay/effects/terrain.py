"""The hull bottom against the terrain (``terrain``), and the vehicle leaving the terrain
(``off_terrain``): at every row with a pose, and at every sub-step of the motion between rows."""

from __future__ import annotations

import numpy as np

from tankcd_cli.collision.terrain_contact import hull_bottom_contacts
from tankcd_cli.matching.match import OFF, OK
from tankcd_cli.replay.effects.effect import Effect, Event, EventKind, Run
from tankcd_cli.tolerances import HULL_CONTACT
from tankcd_cli.vehicle import Vehicle


class Terrain(Effect):
    """The hull bottom on the ground (always run), and the rows and stretches of motion off the
    terrain (the matching's status: no collision)."""

    name = "terrain"
    flag = "terrain_contact"
    kinds = (EventKind("terrain", True, "v", "#e65100", "hull bottom on the ground"),
             EventKind("off_terrain", False, "s", "#424242", "off the terrain"))
    stage = 0

    def runs(self, vehicle: Vehicle, obstacles: bool, turret_moves: bool) -> bool:
        return True

    def at_rows(self, run: Run, kind, chunk, poses, good, where) -> tuple[list, np.ndarray]:
        """Off the terrain: each row whose pose is not wholly on it; the hull bottom: each row with a
        pose where the ground rises above it by more than ``tolerances.HULL_CONTACT``. Contacts (N,)."""
        codes = chunk.entity if chunk.entity is not None else np.zeros(len(chunk), dtype=np.int64)
        events = [Event(int(chunk.step[i]), float(chunk.t[i]), "off_terrain", "vehicle", "terrain",
                        {"status": "off" if poses.status[i] == OFF else "partly_off"}, int(codes[i]))
                  for i in np.flatnonzero(poses.status != OK)]
        contact = np.zeros(len(chunk), dtype=bool)
        if len(good):
            hit, depth = hull_bottom_contacts(run.surface, kind.vehicle, chunk.x[good], chunk.y[good], poses.yaw[good],
                                              poses.plane[good], poses.roll[good], poses.pitch[good], HULL_CONTACT)
            found = [Event(int(chunk.step[good[k]]), float(chunk.t[good[k]]), "terrain", "hull", "terrain",
                           {"depth": round(float(d), 4)}, int(codes[good[k]])) for k, d in zip(hit, depth)]
            contact[[where[e.step] for e in found]] = True
            events += found
        return events, contact

    def along(self, run: Run, kind, block) -> tuple[list, None]:
        """The hull bottom at every sub-step; an event where contact (or leaving the terrain) begins."""
        rows, a, owner, at, sub, placed = block.rows, block.a, block.owner, block.at, block.sub, block.placed
        good = np.flatnonzero((sub.status != OFF) & placed[owner])
        hit = np.zeros(len(owner), dtype=bool)
        depth = np.zeros(len(owner))
        if len(good):
            k, d = hull_bottom_contacts(run.surface, kind.vehicle, at["x"][good], at["y"][good], sub.yaw[good],
                                        sub.plane[good], sub.roll[good], sub.pitch[good], HULL_CONTACT)
            hit[good[k]] = True
            depth[good[k]] = d
        before = np.empty(len(owner), dtype=bool)  # in contact at the placement before each sub-step
        if len(owner):
            before[1:] = hit[:-1]
            starts = np.flatnonzero(np.diff(owner, prepend=-1) != 0)
            before[starts] = rows.contacts[self.name][a[owner[starts]]]
        events = [Event(int(rows.step[a[owner[i]]]), float(at["t"][i]), "terrain", "hull", "terrain",
                        {"depth": round(float(depth[i]), 4), "between": True}, int(rows.entity[a[owner[i]]]))
                  for i in np.flatnonzero(hit & ~before)]
        # a path that leaves the terrain between two rows on it: the first sub-step off, per interval
        off = (sub.status != OK) & placed[owner] & (rows.poses.status[a[owner]] == OK) & \
            (rows.poses.status[a[owner] + 1] == OK)
        _, first_off = np.unique(owner[off], return_index=True)  # the first sub-step off, per interval
        for i in np.flatnonzero(off)[first_off]:
            events.append(Event(int(rows.step[a[owner[i]]]), float(at["t"][i]), "off_terrain", "vehicle",
                                "terrain", {"status": "off" if sub.status[i] == OFF else "partly_off",
                                            "between": True}, int(rows.entity[a[owner[i]]])))
        return events, None


TERRAIN = Terrain()
