"""What an effect is: the one ``Event`` type, the kinds of event, and the ``Effect`` descriptor each
module of ``replay.effects`` fills in (what it checks at the rows, what it checks along the motion,
the counts and seconds it reports)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from tankcd_cli.vehicle import Vehicle


@dataclass
class Event:
    """One event: the row's step, the time (s), the kind (``replay.effects.EVENT_KINDS``), the two
    parts, and what the kind carries (a point, a depth, angles, ``between`` for a contact that began
    between rows, ``entity`` with many vehicles). A contact that begins between two rows has the
    earlier row's step and the time of first contact."""

    step: int
    t: float
    kind: str
    a: str
    b: str
    extra: dict = field(default_factory=dict)
    entity: int = 0  # the vehicle's code in the trajectory (its name, when it has names, is in extra)

    @property
    def between(self) -> bool:
        return bool(self.extra.get("between"))

    def as_dict(self) -> dict:
        """As a line of the events file: step, t, kind, a, b, then the kind's fields."""
        t = None if self.t is None or not np.isfinite(self.t) else round(float(self.t), 6)
        return {"step": int(self.step), "t": t, "kind": self.kind, "a": self.a, "b": self.b, **self.extra}


@dataclass(frozen=True)
class EventKind:
    """A kind of event (a row of docs/formats.md's events "By kind" table).

    name : the events file's ``kind``
    collision : counted among the summary's collisions (``off_terrain`` is no collision)
    marker, colour, label : how the replay picture marks it (matplotlib marker, colour; legend text);
        marker None: not drawn
    """

    name: str
    collision: bool = True
    marker: str | None = None
    colour: str = "#000000"
    label: str = ""


class Run(Protocol):
    """What an effect's checks read of a replay's run (``replay.pipeline.ReplayRun``)."""

    surface: object
    obstacles: list
    world: object
    gates: object  # ``tankcd_cli.gates.GateTally``: what the effects' gates skipped


class Effect:
    """One effect of a replay: a vehicle's own checks at its rows and along its motion (``own``), or
    the checks between the vehicles of an exercise (not ``own``: ``replay.effects.vehicles``).

    name : its key in the summary's ``seconds_by_effect``
    flag : its key in the summary's ``effects`` (which effects ran), for an own effect
    kinds : the kinds of event it makes, in the order docs/formats.md lists them
    stage : where it runs among the effects at a row and along the motion: events of one instant
        keep this order, and so do the summary's ``effects`` and ``seconds_by_effect`` keys
    own : it checks one vehicle's own rows and motion
    """

    name: str = ""
    flag: str = ""
    kinds: tuple[EventKind, ...] = ()
    stage: int = 0
    own: bool = True

    @property
    def kind_names(self) -> tuple[str, ...]:
        return tuple(k.name for k in self.kinds)

    def runs(self, vehicle: Vehicle, obstacles: bool, turret_moves: bool) -> bool:
        """Whether a replay of ``vehicle`` runs this effect, the scene having obstacles or not and the
        trajectory moving the turret or gun or not."""
        return True

    def resolution(self, surface) -> dict:
        """The resolution of its checks along the motion, as the summary's ``motion`` states it."""
        return {}

    def no_contacts(self, run: Run, n: int) -> np.ndarray:
        """(n, ...) bool: no row in contact (the state the checks along the motion start from)."""
        return np.zeros(n, dtype=bool)

    def at_rows(self, run: Run, kind, chunk, poses, good: np.ndarray, where) -> tuple[list, np.ndarray]:
        """The events at the rows of one kind of vehicle (``kind``: a ``replay.world.VehicleKind``) in
        ``chunk`` placed as ``poses``, ``good`` (G,) the rows with a pose, ``where[step]`` each step's
        row (``replay.pipeline.StepRows``); and (N, ...) bool the rows' contacts (what the checks
        along the motion take)."""
        raise NotImplementedError

    def along(self, run: Run, kind, block) -> tuple[list, np.ndarray | None]:
        """The events that begin along a block of the motion (``replay.between_rows.MotionBlock``);
        and (N, ...) bool per row whether the stretch of motion ending there touched (OR-ed into the
        row's contacts when it is carried into the next chunk), or None."""
        raise NotImplementedError
