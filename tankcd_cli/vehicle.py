"""Vehicle descriptions and the built-in presets.

Vehicle frame: x forward, y left, z up, origin at the centre of the hull's
ground-contact footprint (between the tracks, halfway along the contact
length, at track-bottom height). Lengths in metres, angles in degrees only in
the preset tables (``gun_min_deg``, ``gun_max_deg``).

Sources ("(estimate)" where no source states a value directly):

- T-72: tankimira.ru "T-72 Ural" (hull length 6.86 m, width 3.46 m, height
  2.19-2.23 m); Simple English Wikipedia "T-72" (9.53 m with the gun forward,
  ground clearance 0.49 m); Chinese Wikipedia "T-72" (3.59 m with skirts);
  DCS World chassis data (track gauge 2.79 m and contact length 4.28 m,
  estimates); 580 mm tracks (commonly quoted); 125 mm 2A46 gun, 48 calibres
  = 6.0 m tube; elevation -6 to +14 deg (estimate); two 200 L drums on the
  rear plate, axes across the hull, 0.6 m diameter, 0.88 m long (industrial
  drum standards). Trunnion placement: 9.53 m overall minus half the hull
  leaves 6.1 m ahead of the footprint centre, so with a 6.0 m tube the
  trunnion sits 0.1 m ahead of it, 0.45 m ahead of the turret ring centre
  (estimate). Heights of the trunnion (1.75 m), the deck (1.35 m) and the
  drum axes (1.20 m) are estimates chosen so that, turned to the rear, the
  barrel clears the drums level and meets them at full depression, as the
  paper describes. The drums sit side by side 1.0 m apart (a 0.12 m gap
  between their ends, narrower than the barrel). Six road wheels a side
  (recognition guides).
- T-55: width 3.27 m; DCS World chassis data (contact stations 3.96 m apart,
  gauge 2.60 m); 100 mm D-10T, tube about 5.35 m; elevation -5 to +18 deg
  (estimates); hull length 6.20 m, height 2.32 m, ground clearance 0.425 m
  and 580 mm tracks as commonly quoted (estimates); two 200 L rear drums; five
  road wheels a side (commonly quoted).
- M1 Abrams: hull length 7.92 m, width 3.66 m, height 2.38-2.44 m; 120 mm
  M256 L/44, tube 5.28 m; DCS World chassis data (contact stations 4.76 m
  apart, gauge 2.86 m); elevation -10 to +20 deg (estimate); ground clearance
  0.48 m and 635 mm tracks as commonly quoted (estimates); no external drums;
  seven road wheels a side (commonly quoted).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from tankcd_cli.names import PRESET_NAMES

import math


@dataclass(frozen=True)
class Vehicle:
    """Dimensions of a tracked vehicle, m (angles in degrees).

    track_length : ground-contact length of each track
    track_gauge : distance between the two tracks' centre lines
    track_width : width of each track
    hull_length, hull_width : hull box, centred on the footprint
    hull_height : to the turret roof
    deck_height : top of the hull (engine deck) above the track bottom
    ground_clearance : hull bottom above the track bottom
    turret_x : turret ring centre, ahead of the footprint centre
    trunnion_forward : trunnion ahead of the turret ring centre (turret frame)
    trunnion_height : trunnion axis above the track bottom
    gun_length : trunnion to muzzle
    gun_radius : outer radius of the barrel
    gun_min_deg, gun_max_deg : elevation limits
    fuel_drums : whether the two rear drums are fitted
    drum_radius, drum_length : each drum (axis across the hull, along y)
    drum_x, drum_y, drum_z : centre of the left drum (the right one mirrors y)
    road_wheels : road wheels on each side (the stations ``wheel_stations`` samples), 2 to 20
    """

    name: str
    track_length: float
    track_gauge: float
    track_width: float
    hull_length: float
    hull_width: float
    hull_height: float
    deck_height: float
    ground_clearance: float
    turret_x: float
    trunnion_forward: float
    trunnion_height: float
    gun_length: float
    gun_radius: float
    gun_min_deg: float
    gun_max_deg: float
    fuel_drums: bool
    drum_radius: float
    drum_length: float
    drum_x: float
    drum_y: float
    drum_z: float
    road_wheels: int = 6  # a default, so that a Vehicle built without it (older code, tests) is a T-72's

    def __post_init__(self):
        positive = ("track_length", "track_gauge", "track_width", "hull_length", "hull_width", "hull_height",
                    "deck_height", "ground_clearance", "trunnion_height", "gun_length", "gun_radius",
                    "drum_radius", "drum_length")
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "name":
                continue
            if f.name == "road_wheels":
                if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= 20:
                    raise ValueError(f"vehicle road_wheels must be a whole number from 2 to 20, got {value!r}")
                continue
            if f.name == "fuel_drums":
                if not isinstance(value, bool):
                    raise ValueError(f"vehicle fuel_drums must be true or false, got {value!r}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"vehicle {f.name} must be a finite number, got {value!r}")
            if f.name in positive and not (0 < value < 1e3):
                raise ValueError(f"vehicle {f.name} must be a positive length below 1 km, got {value!r}")
        if self.track_width >= self.track_gauge:
            raise ValueError("vehicle track_width must be smaller than track_gauge (the tracks would overlap)")
        if not (-90 < self.gun_min_deg <= self.gun_max_deg < 90):
            raise ValueError("vehicle gun elevation limits need -90 < gun_min_deg <= gun_max_deg < 90")
        if self.ground_clearance >= self.deck_height or self.deck_height > self.hull_height:
            raise ValueError("vehicle heights need ground_clearance < deck_height <= hull_height")

    @property
    def footprint_width(self) -> float:
        """Outer width of the two tracks' contact patches, m."""
        return self.track_gauge + self.track_width


def _t72() -> Vehicle:
    half_hull = 6.86 / 2
    return Vehicle("t72", track_length=4.28, track_gauge=2.79, track_width=0.58,
                   hull_length=6.86, hull_width=3.46, hull_height=2.19, deck_height=1.35, ground_clearance=0.49,
                   turret_x=-0.35, trunnion_forward=0.45, trunnion_height=1.75, gun_length=6.0, gun_radius=0.11,
                   gun_min_deg=-6.0, gun_max_deg=14.0, fuel_drums=True, drum_radius=0.30, drum_length=0.88,
                   drum_x=-(half_hull + 0.30), drum_y=0.50, drum_z=1.20, road_wheels=6)


def _t55() -> Vehicle:
    half_hull = 6.20 / 2
    return Vehicle("t55", track_length=3.96, track_gauge=2.60, track_width=0.58,
                   hull_length=6.20, hull_width=3.27, hull_height=2.32, deck_height=1.40, ground_clearance=0.425,
                   turret_x=-0.20, trunnion_forward=0.40, trunnion_height=1.80, gun_length=5.35, gun_radius=0.10,
                   gun_min_deg=-5.0, gun_max_deg=18.0, fuel_drums=True, drum_radius=0.30, drum_length=0.88,
                   drum_x=-(half_hull + 0.30), drum_y=0.50, drum_z=1.25, road_wheels=5)


def _m1() -> Vehicle:
    half_hull = 7.92 / 2
    return Vehicle("m1", track_length=4.76, track_gauge=2.86, track_width=0.635,
                   hull_length=7.92, hull_width=3.66, hull_height=2.44, deck_height=1.40, ground_clearance=0.48,
                   turret_x=-0.40, trunnion_forward=0.55, trunnion_height=1.90, gun_length=5.28, gun_radius=0.11,
                   gun_min_deg=-10.0, gun_max_deg=20.0, fuel_drums=False, drum_radius=0.30, drum_length=0.88,
                   drum_x=-(half_hull + 0.30), drum_y=0.50, drum_z=1.20, road_wheels=7)


PRESETS: dict[str, Vehicle] = dict(zip(PRESET_NAMES, (_t72(), _t55(), _m1())))


def vehicle_preset(name: str = "t72", **overrides) -> Vehicle:
    """A preset by name, with any dimensions overridden (``ValueError`` lists the valid names)."""
    key = name.lower()
    if key not in PRESETS:
        raise ValueError(f"unknown vehicle preset {name!r}; choose one of {', '.join(PRESETS)}")
    unknown = set(overrides) - {f.name for f in fields(Vehicle)}
    if unknown:
        raise ValueError(f"unknown vehicle key {sorted(unknown)[0]!r}")
    return replace(PRESETS[key], **overrides) if overrides else PRESETS[key]


def key_points(vehicle: Vehicle, count: int):
    """Key points (count, 2) in the vehicle frame's ground plane (x forward, y left), m.

    2: the front and rear midpoints of the footprint (the paper's hull-bottom
       midpoints, taken where the tracks touch the ground: the hull bottom
       overhangs the contact length and never rests on the ground);
    4: the corners of the footprint on the tracks' centre lines (the paper:
       ad and bc the contact length, ab and cd the distance between tracks);
    6: front, middle and rear of each track's centre line.
    Order: front before rear, left before right.
    """
    h, g = vehicle.track_length / 2, vehicle.track_gauge / 2
    if count == 2:
        return np.array([[h, 0.0], [-h, 0.0]])
    if count == 4:
        return np.array([[h, g], [h, -g], [-h, -g], [-h, g]])  # a b c d around the rectangle
    if count == 6:
        return np.array([[h, g], [0.0, g], [-h, g], [h, -g], [0.0, -g], [-h, -g]])
    raise ValueError("key points come in 2, 4 or 6")


def wheel_stations(vehicle: Vehicle):
    """Ground samples (4 road_wheels, 2) in the vehicle frame's ground plane, m: every road-wheel
    station of each track (evenly spaced over the contact length, the first and last at its
    ends), each at both edges of the track, where a track on uneven ground bears.
    Order: left track then right, front to rear, outer edge before inner.
    """
    h, g, w = vehicle.track_length / 2, vehicle.track_gauge / 2, vehicle.track_width / 2
    u = np.linspace(h, -h, vehicle.road_wheels)
    rows = [(s * (g + w), s * (g - w)) for s in (1.0, -1.0)]  # each track's outer and inner edge
    return np.array([[ui, edge] for outer_inner in rows for ui in u for edge in outer_inner])
