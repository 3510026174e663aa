"""The gun against the rear fuel drums (``internal``): at the rows' turret and gun angles, and along
the straight path in (azimuth, elevation) between rows to ``collision.internal.GUN_PATH_STEP_DEG``.

Its gate, ``drum_window`` (off with the run's gates): a row whose azimuth, or a path whose arc of
azimuths, stays outside the arc where the barrel can reach a drum at any elevation
(``collision.internal.drum_window``) takes no exact test; the summary's ``gates`` counts the rows
and paths it was asked about and those it cleared."""

from __future__ import annotations

import numpy as np

from tankcd_cli.collision.internal import (
    DRUMS,
    GUN_PATH_STEP_DEG,
    drum_window,
    drum_window_clear,
    first_gun_contacts,
    gun_hits_drums,
)
from tankcd_cli.replay.effects.effect import Effect, Event, EventKind, Run
from tankcd_cli.vehicle import Vehicle


class Internal(Effect):
    """The gun against the drums: run only with drums fitted and a trajectory that moves the turret
    or gun (turret columns)."""

    name = "internal"
    flag = "internal"
    kinds = (EventKind("internal", True, "o", "#6a1b9a", "gun against a drum"),)
    stage = 2

    def runs(self, vehicle: Vehicle, obstacles: bool, turret_moves: bool) -> bool:
        return bool(vehicle.fuel_drums and turret_moves)

    def resolution(self, surface) -> dict:
        """The gun path's step, deg, as the summary states it."""
        return {"gun_step_deg": GUN_PATH_STEP_DEG}

    def at_rows(self, run: Run, kind, chunk, poses, good, where) -> tuple[list, np.ndarray]:
        """An event per row and drum the gun touches (every row: the angles need no pose). Contacts (N,)."""
        azimuth, elevation = np.radians(chunk.turret_deg), np.radians(chunk.gun_deg)
        test = _unproven(run, kind.vehicle, azimuth, np.zeros(len(azimuth)), elevation, np.zeros(len(azimuth)))
        hit = np.zeros((len(azimuth), len(DRUMS)), dtype=bool)
        if len(test):
            hit[test] = gun_hits_drums(kind.vehicle, azimuth[test], elevation[test])
        rows, drums = np.nonzero(hit)
        codes = chunk.entity if chunk.entity is not None else np.zeros(len(chunk), dtype=np.int64)
        events = [Event(int(chunk.step[r]), float(chunk.t[r]), "internal", "gun", DRUMS[d],
                        {"turret_deg": round(float(chunk.turret_deg[r]), 3),
                         "gun_deg": round(float(chunk.gun_deg[r]), 3)}, int(codes[r]))
                  for r, d in zip(rows, drums)]
        contact = np.zeros(len(chunk), dtype=bool)
        contact[[where[e.step] for e in events]] = True
        return events, contact

    def along(self, run: Run, kind, block) -> tuple[list, None]:
        """The gun along each interval's angle path, for intervals whose first row is clear of the drums."""
        rows, iv, a = block.rows, block.iv, block.a
        moving = np.flatnonzero(((iv.dturret != 0) | (iv.dgun != 0)) & ~rows.contacts[self.name][a])
        paths = [np.radians(v[moving]) for v in (iv.turret0, iv.dturret, iv.gun0, iv.dgun)]
        test = _unproven(run, kind.vehicle, *paths)
        moving, paths = moving[test], [p[test] for p in paths]
        if len(moving) == 0:
            return [], None
        found, s, drum = first_gun_contacts(kind.vehicle, *paths)
        events = []
        for j in np.flatnonzero(found & (s > 0)):
            k = moving[j]
            turret = iv.turret0[k] + s[j] * iv.dturret[k]
            turret = (turret + 180.0) % 360.0 - 180.0
            events.append(Event(int(rows.step[a[k]]), float(iv.t0[k] + s[j] * iv.dt[k]), "internal", "gun",
                                DRUMS[drum[j]], {"turret_deg": round(float(turret), 3),
                                                 "gun_deg": round(float(iv.gun0[k] + s[j] * iv.dgun[k]), 3),
                                                 "between": True}, int(rows.entity[a[k]])))
        return events, None


def _unproven(run: Run, vehicle: Vehicle, azimuth0, dazimuth, elevation0, delevation) -> np.ndarray:
    """The indices of the gun's positions or paths (M,) rad that the ``drum_window`` gate cannot
    clear (all of them with the gates off), counted in the run's gates."""
    gates = getattr(run, "gates", None)
    if gates is None or not gates.enabled or len(azimuth0) == 0:
        return np.arange(len(azimuth0))
    clear = drum_window_clear(drum_window(vehicle), azimuth0, dazimuth, elevation0, delevation)
    gates.add("drum_window", len(clear), int(clear.sum()))
    return np.flatnonzero(~clear)


INTERNAL = Internal()
