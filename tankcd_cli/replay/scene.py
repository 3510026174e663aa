"""Scenes (TOML): the terrain, the vehicle and what else is in the world, validated strictly.

```toml
[terrain]
path = "terrain.h5"          # a store from classify, or any terrain input
up = "z"                     # for a mesh classified on the fly

[vehicle]
preset = "t72"               # t72, t55, m1
track_length = 4.3           # any dimension of tankcd_cli.vehicle.Vehicle overrides the preset
fuel_drums = true
mesh = "tank.obj"            # optional: the vehicle's shape, in the vehicle frame
mesh_up = "z"

[[obstacle]]
name = "depot"
path = "depot.obj"
up = "z"                     # "y" for y-up meshes
position = [0.0, 0.0, 0.0]   # where the mesh's origin goes in the world, m
yaw_deg = 0.0                # turn about +z, counter-clockwise

[collision]                  # optional: how obstacle trees are built
k = 18                       # k-DOP type: 6, 14, 18, 26
aabb_levels = 2              # top levels that use only the AABB
split = "sah"                # or "median"
leaf_size = 4
```

Relative paths are relative to the scene file. Unknown keys, wrong types,
missing files and out-of-range values are bad input (exit 3) naming the key.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields

from tankcd_cli.errors import InputError
from tankcd_cli.vehicle import PRESETS, Vehicle, vehicle_preset

VEHICLE_KEYS = {f.name for f in fields(Vehicle)} - {"name"}


@dataclass(frozen=True)
class ObstacleSpec:
    name: str
    path: str
    up: str
    position: tuple
    yaw_deg: float


@dataclass(frozen=True)
class CollisionSettings:
    k: int = 18
    aabb_levels: int = 2
    split: str = "sah"
    leaf_size: int = 4


@dataclass
class Scene:
    path: str
    terrain_path: str | None
    terrain_up: str
    vehicle: Vehicle
    vehicle_mesh: str | None
    vehicle_mesh_up: str
    obstacles: list = field(default_factory=list)
    collision: CollisionSettings = CollisionSettings()

    def effects(self, turret_moves: bool) -> dict:
        """Which effects a replay of this scene simulates (the scene decides, not the user)."""
        return {"terrain_contact": True,
                "obstacles": bool(self.obstacles),
                "internal": bool(self.vehicle.fuel_drums and turret_moves)}

    def describe(self) -> dict:
        return {
            "scene": self.path,
            "terrain": self.terrain_path,
            "vehicle": self.vehicle.name,
            "vehicle mesh": self.vehicle_mesh or "generated from the preset's dimensions",
            "fuel drums": self.vehicle.fuel_drums,
            "obstacles": [o.name for o in self.obstacles],
            "collision volumes": f"k = {self.collision.k}, AABB levels {self.collision.aabb_levels}, "
                                 f"split {self.collision.split}, leaf size {self.collision.leaf_size}",
            "effects (turret moving)": self.effects(True),
            "effects (turret still)": self.effects(False),
        }


def load_scene(path: str) -> Scene:
    import tomllib

    try:
        with open(path, "rb") as fh:
            raw = fh.read()
        # editors on Windows write a byte-order mark, which TOML does not allow
        data = tomllib.loads(raw.decode("utf-8-sig"))
    except FileNotFoundError:
        raise InputError(path, "no such file") from None
    except IsADirectoryError:
        raise InputError(path, "is a directory, not a file") from None
    except PermissionError:
        raise InputError(path, "permission denied") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not valid TOML: {exc}") from None
    base = os.path.dirname(os.path.abspath(path))
    _only(data, {"terrain", "vehicle", "obstacle", "collision"}, path, "")

    terrain = _table(data, "terrain", path)
    _only(terrain, {"path", "up"}, path, "[terrain]")
    terrain_path = _file(terrain, "path", base, path, "[terrain]") if "path" in terrain else None
    terrain_up = _choice(terrain, "up", ("z", "y"), "z", path, "[terrain]")

    veh = _table(data, "vehicle", path)
    _only(veh, VEHICLE_KEYS | {"preset", "mesh", "mesh_up"}, path, "[vehicle]")
    preset = veh.get("preset", "t72")
    if not isinstance(preset, str) or preset.lower() not in PRESETS:
        raise InputError(path, f"unknown preset {preset!r}; choose one of {', '.join(PRESETS)}", where="[vehicle] preset")
    overrides = {}
    for key in sorted(VEHICLE_KEYS & set(veh)):
        value = veh[key]
        if key == "fuel_drums":
            if not isinstance(value, bool):
                raise InputError(path, f"must be true or false, got {value!r}", where="[vehicle] fuel_drums")
        elif isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(path, f"must be a number, got {value!r}", where=f"[vehicle] {key}")
        overrides[key] = float(value) if key != "fuel_drums" else value
    try:
        vehicle = vehicle_preset(preset, **overrides)
    except ValueError as exc:
        raise InputError(path, str(exc), where="[vehicle]") from None
    mesh = _file(veh, "mesh", base, path, "[vehicle]") if "mesh" in veh else None
    mesh_up = _choice(veh, "mesh_up", ("z", "y"), "z", path, "[vehicle]")

    raw_obstacles = data.get("obstacle", [])
    if not isinstance(raw_obstacles, list):
        raise InputError(path, "obstacles are written [[obstacle]]", where="obstacle")
    obstacles = []
    names = set()
    for i, ob in enumerate(raw_obstacles):
        where = f"[[obstacle]] {i + 1}"
        if not isinstance(ob, dict):
            raise InputError(path, "must be a table", where=where)
        _only(ob, {"name", "path", "up", "position", "yaw_deg"}, path, where)
        name = ob.get("name", f"obstacle{i + 1}")
        if not isinstance(name, str) or not name:
            raise InputError(path, "name must be a non-empty string", where=f"{where} name")
        if name in names:
            raise InputError(path, f"obstacle name {name!r} used twice", where=f"{where} name")
        names.add(name)
        if "path" not in ob:
            raise InputError(path, "an obstacle needs a path", where=f"{where} path")
        position = ob.get("position", [0.0, 0.0, 0.0])
        if (not isinstance(position, list) or len(position) != 3
                or not all(isinstance(p, (int, float)) and not isinstance(p, bool) and math.isfinite(p) for p in position)):
            raise InputError(path, f"position must be three finite numbers [x, y, z], got {position!r}", where=f"{where} position")
        yaw = ob.get("yaw_deg", 0.0)
        if isinstance(yaw, bool) or not isinstance(yaw, (int, float)) or not math.isfinite(yaw):
            raise InputError(path, f"yaw_deg must be a finite number, got {yaw!r}", where=f"{where} yaw_deg")
        obstacles.append(ObstacleSpec(name, _file(ob, "path", base, path, where),
                                      _choice(ob, "up", ("z", "y"), "z", path, where),
                                      tuple(float(p) for p in position), float(yaw)))

    col = _table(data, "collision", path)
    _only(col, {"k", "aabb_levels", "split", "leaf_size"}, path, "[collision]")
    k = col.get("k", 18)
    if k not in (6, 14, 18, 26) or isinstance(k, bool):
        raise InputError(path, f"k must be 6, 14, 18 or 26, got {k!r}", where="[collision] k")
    levels = col.get("aabb_levels", 2)
    if not isinstance(levels, int) or isinstance(levels, bool) or levels < 0:
        raise InputError(path, f"aabb_levels must be a whole number >= 0, got {levels!r}", where="[collision] aabb_levels")
    split = _choice(col, "split", ("median", "sah"), "sah", path, "[collision]")
    leaf = col.get("leaf_size", 4)
    if not isinstance(leaf, int) or isinstance(leaf, bool) or not 1 <= leaf <= 64:
        raise InputError(path, f"leaf_size must be a whole number from 1 to 64, got {leaf!r}", where="[collision] leaf_size")
    return Scene(path, terrain_path, terrain_up, vehicle, mesh, mesh_up, obstacles,
                 CollisionSettings(int(k), int(levels), split, int(leaf)))


def _table(data, key, path):
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise InputError(path, "must be a table", where=f"[{key}]")
    return value


def _only(table, allowed, path, where):
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InputError(path, f"unknown key {unknown[0]!r} (known: {', '.join(sorted(allowed))})",
                         where=f"{where} {unknown[0]}".strip())


def _choice(table, key, options, default, path, where):
    value = table.get(key, default)
    if value not in options:
        raise InputError(path, f"must be one of {', '.join(options)}, got {value!r}", where=f"{where} {key}")
    return value


def _file(table, key, base, path, where):
    value = table[key]
    if not isinstance(value, str) or not value:
        raise InputError(path, f"must be a file path, got {value!r}", where=f"{where} {key}")
    full = value if os.path.isabs(value) else os.path.join(base, value)
    if not os.path.isfile(full):
        raise InputError(path, f"file not found: {value}", where=f"{where} {key}")
    return full
