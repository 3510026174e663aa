"""Vehicle descriptions and the built-in presets.

Vehicle frame: x forward, y left, z up, origin at the centre of the hull's
ground-contact footprint (between the tracks, halfway along the contact
length, at track-bottom height). Lengths in metres.

Sources (see also shared docs ``vehicles.md``):

- T-72: tankimira.ru "T-72 Ural" (hull length, width, height); Simple English
  Wikipedia "T-72" (overall length 9.53 m, height, ground clearance 0.49 m);
  Chinese Wikipedia "T-72" (3.59 m width with skirts); DCS World chassis data
  for the T-72 (track gauge and contact length, estimates); track width
  commonly quoted (estimate).
- T-55: width 3.27 m; DCS World chassis data (contact stations 3.96 m apart,
  gauge 2.60 m); hull length 6.20 m, height 2.32 m, ground clearance 0.425 m
  and 580 mm tracks as commonly quoted (estimates).
- M1 Abrams: hull length 7.92 m, width 3.66 m, height 2.38-2.44 m; DCS World
  chassis data (contact stations 4.76 m apart, gauge 2.86 m); ground
  clearance 0.48 m and 635 mm tracks as commonly quoted (estimates).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace


@dataclass(frozen=True)
class Vehicle:
    """Dimensions of a tracked vehicle, m.

    track_length : ground-contact length of each track
    track_gauge : distance between the two tracks' centre lines
    track_width : width of each track
    hull_length, hull_width, hull_height : overall hull box (height to the turret roof)
    ground_clearance : hull bottom above the track bottom
    """

    name: str
    track_length: float
    track_gauge: float
    track_width: float
    hull_length: float
    hull_width: float
    hull_height: float
    ground_clearance: float

    def __post_init__(self):
        for f in fields(self):
            if f.name == "name":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and value > 0 and value < 1e3):
                raise ValueError(f"vehicle {f.name} must be a positive length in metres, got {value!r}")
        if self.track_width >= self.track_gauge:
            raise ValueError("track_width must be smaller than track_gauge (the tracks would overlap)")

    @property
    def footprint_width(self) -> float:
        """Outer width of the two tracks' contact patches, m."""
        return self.track_gauge + self.track_width


PRESETS: dict[str, Vehicle] = {
    "t72": Vehicle("t72", track_length=4.28, track_gauge=2.79, track_width=0.58,
                   hull_length=6.86, hull_width=3.46, hull_height=2.19, ground_clearance=0.49),
    "t55": Vehicle("t55", track_length=3.96, track_gauge=2.60, track_width=0.58,
                   hull_length=6.20, hull_width=3.27, hull_height=2.32, ground_clearance=0.425),
    "m1": Vehicle("m1", track_length=4.76, track_gauge=2.86, track_width=0.635,
                  hull_length=7.92, hull_width=3.66, hull_height=2.44, ground_clearance=0.48),
}


def vehicle_preset(name: str = "t72", **overrides: float) -> Vehicle:
    """A preset by name, with any dimensions overridden."""
    key = name.lower()
    if key not in PRESETS:
        raise ValueError(f"unknown vehicle preset {name!r}; choose one of {', '.join(PRESETS)}")
    return replace(PRESETS[key], **overrides) if overrides else PRESETS[key]
