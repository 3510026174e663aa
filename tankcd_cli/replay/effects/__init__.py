"""A replay's effects, one module each, behind one registry (``EFFECTS``): what each checks at the
rows and along the motion between them, the kinds of event it makes, and the counts and seconds it
reports. ``Effects`` (which ran), the summary's keys, the events' kinds (``replay.records``), the
picture's markers (``plots``) and the trade-off report's contact kinds all read the registry.

To add an effect: a module here with an ``Effect`` (docs/development.md, "How to add an effect"),
one line in ``EFFECTS``, and its kinds' rows in docs/formats.md's events table.
"""

from __future__ import annotations

from dataclasses import dataclass

from tankcd_cli.replay.effects.effect import Effect, Event, EventKind
from tankcd_cli.replay.effects.internal import INTERNAL
from tankcd_cli.replay.effects.obstacles import OBSTACLES
from tankcd_cli.replay.effects.terrain import TERRAIN
from tankcd_cli.replay.effects.vehicles import VEHICLES
from tankcd_cli.replay.between_rows import motion_resolution
from tankcd_cli.vehicle import Vehicle

# every effect, in the order their kinds of event are listed (docs/formats.md, the summary's counts)
EFFECTS: tuple[Effect, ...] = (OBSTACLES, INTERNAL, TERRAIN, VEHICLES)

#: the order the effects run in at the rows and along the motion (``Effect.stage``)
BY_STAGE: tuple[Effect, ...] = tuple(sorted(EFFECTS, key=lambda e: e.stage))
#: a vehicle's own effects, in the order they run (the summary's ``effects`` and seconds keys)
OWN: tuple[Effect, ...] = tuple(e for e in BY_STAGE if e.own)

EVENT_KIND_TABLE: tuple[EventKind, ...] = tuple(k for e in EFFECTS for k in e.kinds)
ALL_KINDS: tuple[str, ...] = tuple(k.name for k in EVENT_KIND_TABLE)  # every kind of event, vehicle's too
#: the kinds of a vehicle's own events (what the summary counts at and between rows, by kind)
EVENT_KINDS: tuple[str, ...] = tuple(k.name for e in EFFECTS if e.own for k in e.kinds)
#: a vehicle's own collision kinds (the summary's ``collisions``; ``off_terrain`` is no collision)
KINDS: tuple[str, ...] = tuple(k.name for e in EFFECTS if e.own for k in e.kinds if k.collision)


@dataclass(frozen=True, init=False)
class Effects:
    """Which of a vehicle's own effects a replay runs (the scene decides), a flag per effect of
    ``OWN`` (positional, in that order), read by its ``flag``: ``terrain_contact`` (the hull bottom
    against the terrain), ``obstacles`` (the vehicle against obstacles), ``internal`` (the gun
    against the drums)."""

    on: tuple

    def __init__(self, *on: bool):
        if len(on) != len(OWN):
            raise TypeError(f"Effects takes {len(OWN)} flags ({', '.join(e.flag for e in OWN)}), not {len(on)}")
        object.__setattr__(self, "on", tuple(bool(v) for v in on))

    def __getattr__(self, name: str) -> bool:
        if name != "on" and not name.startswith("__"):
            for effect, v in zip(OWN, self.on):
                if effect.flag == name:
                    return v
        raise AttributeError(name)

    def __getitem__(self, name: str) -> bool:
        return getattr(self, name)

    def running(self) -> list[Effect]:
        """The effects that run, in their stage order."""
        return [e for e, v in zip(OWN, self.on) if v]

    def as_dict(self) -> dict:
        return {e.flag: v for e, v in zip(OWN, self.on)}

    @staticmethod
    def any_of(met: list["Effects"]) -> "Effects":
        """Each effect that runs in any of ``met`` (a replay's kinds of vehicle)."""
        return Effects(*(any(m.on[i] for m in met) for i in range(len(OWN))))


def effects_for(vehicle: Vehicle, obstacles: bool, turret_moves: bool) -> Effects:
    """The effects a replay of ``vehicle`` simulates (``Effect.runs``): the hull bottom against the
    terrain always; obstacle checks only with obstacles; the gun against the drums only with drums
    fitted and a turret that moves (a trajectory with turret columns)."""
    return Effects(*(e.runs(vehicle, obstacles, turret_moves) for e in OWN))


def seconds_keys(continuous: bool, entities: bool) -> list[str]:
    """The summary's ``seconds_by_effect`` keys, in order: the matching, each own effect, the motion
    between rows (continuous only), the checks between vehicles (an exercise only)."""
    return (["matching"] + [e.name for e in OWN] + (["between"] if continuous else [])
            + ([e.name for e in BY_STAGE if not e.own] if entities else []))


def resolution(surface) -> dict:
    """The resolution of the checks between rows, as the summary states it: the sub-steps', then
    each own effect's."""
    out = motion_resolution(surface)
    for e in OWN:
        out.update(e.resolution(surface))
    return out


__all__ = ["ALL_KINDS", "BY_STAGE", "EFFECTS", "EVENT_KINDS", "EVENT_KIND_TABLE", "Effect", "Effects", "Event",
           "EventKind", "KINDS", "OWN", "effects_for", "resolution", "seconds_keys"]
