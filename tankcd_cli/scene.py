"""Scenes (TOML): the terrain, the vehicle and what else is in the world, validated strictly.

The schema (every table and key, its default and its checks, and how an obstacle's mesh is
placed in the world) is documented once, in docs/formats.md, "Scene (TOML)". ``load_scene``
reads a scene into a ``Scene``, or raises ``InputError`` naming the key at fault.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields

from tankcd_cli.errors import InputError
from tankcd_cli.names import KDOP_KS, SPLITS, TREE_DEFAULTS, UP_AXES
from tankcd_cli.vehicle import PRESETS, Vehicle, vehicle_preset

VEHICLE_KEYS = {f.name for f in fields(Vehicle)} - {"name"}
# a heightmap's [terrain] keys (io.heightmap.HeightmapSpec's fields)
HEIGHTMAP_KEYS = ("spacing", "z_scale", "z_offset", "z_range", "origin", "crs", "size", "band")


class TerrainPath(str):
    """A scene's terrain path, carrying how to read it: ``heightmap``, the
    :class:`~tankcd_cli.io.heightmap.HeightmapSpec` of the [terrain] table's heightmap keys
    (None without them). Whatever opens the scene's terrain (``terrain.open``) reads a heightmap
    as the scene says through it."""

    heightmap = None

    def __new__(cls, path: str, heightmap=None):
        self = super().__new__(cls, path)
        self.heightmap = heightmap
        return self

    def __reduce__(self):  # pickled (to a worker) with its settings
        return (TerrainPath, (str(self), self.heightmap))


@dataclass(frozen=True)
class ObstacleSpec:
    """An obstacle as the scene places it: world = position + R(yaw, pitch, roll) @ (scale * mesh point)."""

    name: str
    path: str
    up: str | None  # None: the format's convention
    position: tuple
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    scale: tuple = (1.0, 1.0, 1.0)

    def placement(self) -> dict:
        return {"up": self.up, "position": list(self.position), "yaw_deg": self.yaw_deg,
                "pitch_deg": self.pitch_deg, "roll_deg": self.roll_deg, "scale": list(self.scale)}


@dataclass(frozen=True)
class MeshPlacement:
    """How the vehicle mesh is brought into the vehicle frame: R(yaw, pitch, roll) @ (scale * mesh point)."""

    up: str | None = None
    scale: tuple = (1.0, 1.0, 1.0)
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0

    def placement(self) -> dict:
        return {"up": self.up, "yaw_deg": self.yaw_deg, "pitch_deg": self.pitch_deg, "roll_deg": self.roll_deg,
                "scale": list(self.scale)}


@dataclass(frozen=True)
class CollisionSettings:
    k: int = TREE_DEFAULTS["k"]
    aabb_levels: int = TREE_DEFAULTS["aabb_levels"]
    split: str = TREE_DEFAULTS["split"]
    leaf_size: int = TREE_DEFAULTS["leaf_size"]

    def describe(self) -> dict:
        return {"k": self.k, "aabb_levels": self.aabb_levels, "split": self.split, "leaf_size": self.leaf_size}


@dataclass(frozen=True)
class EntityVehicle:
    """Which vehicle the entities an [[entity]] table names are: an ``id`` (one entity) or a
    ``match`` pattern of ids (``*`` and ``?``, as shell globs), the vehicle and its mesh."""

    id: str | None
    match: str | None
    vehicle: Vehicle
    mesh: str | None = None
    mesh_placement: MeshPlacement = MeshPlacement()

    def names(self, entity: str) -> bool:
        from fnmatch import fnmatchcase

        return entity == self.id if self.id is not None else fnmatchcase(entity, self.match)

    @property
    def label(self) -> str:
        return f"id {self.id}" if self.id is not None else f"match {self.match}"


@dataclass
class Scene:
    path: str
    terrain_path: str | None
    terrain_up_axis: str | None  # as written; None: the format's convention
    vehicle: Vehicle
    vehicle_mesh: str | None
    vehicle_mesh_placement: MeshPlacement = MeshPlacement()
    obstacles: list = field(default_factory=list)
    collision: CollisionSettings = CollisionSettings()
    entities: list = field(default_factory=list)  # EntityVehicle tables, first match wins

    def entity_vehicle(self, entity: str) -> int:
        """Which vehicle an entity is: 0 the [vehicle] table's, k the k-th [[entity]] table's (the
        first that names it)."""
        for k, table in enumerate(self.entities):
            if table.names(entity):
                return k + 1
        return 0

    @property
    def terrain_up(self) -> str | None:
        """The terrain's up axis as the terrain readers take it (None: the format's convention)."""
        return self.terrain_up_axis

    @property
    def terrain_heightmap(self):
        """The terrain's HeightmapSpec (a heightmap's [terrain] keys), or None."""
        return getattr(self.terrain_path, "heightmap", None)

    @property
    def vehicle_mesh_up(self) -> str | None:
        return self.vehicle_mesh_placement.up

    def required_terrain(self) -> str:
        """The terrain path, for the commands that need one (bad input naming the key if none)."""
        if self.terrain_path is None:
            raise InputError(self.path, "names no [terrain] path; this command needs a terrain",
                             where="[terrain] path")
        return self.terrain_path

    def describe(self) -> dict:
        """The resolved scene as plain, nested values with snake_case keys (no file is read;
        ``tankcd_cli.describe.describe_scene`` adds what the files hold)."""
        v = self.vehicle
        return {
            "file": self.path,
            "kind": "scene",
            "terrain": {"path": self.terrain_path, "up": self.terrain_up_axis, **self._heightmap_facts()},
            "vehicle": {
                "name": v.name,
                "fuel_drums": v.fuel_drums,
                "dimensions": {k: getattr(v, k) for k in sorted(VEHICLE_KEYS) if k != "fuel_drums"},
                "mesh": ({"path": self.vehicle_mesh, **self.vehicle_mesh_placement.placement()} if self.vehicle_mesh
                         else None),
            },
            "obstacles": [{"name": o.name, "path": o.path, **o.placement()} for o in self.obstacles],
            "entities": [{"id": t.id, "match": t.match, "vehicle": t.vehicle.name, "fuel_drums": t.vehicle.fuel_drums,
                          "mesh": t.mesh} for t in self.entities],
            "collision": self.collision.describe(),
        }


    def _heightmap_facts(self) -> dict:
        spec = self.terrain_heightmap
        if spec is None:
            return {}
        return {"heightmap": {k: (list(v) if isinstance(v, tuple) else v) for k in spec.given()
                              for v in (getattr(spec, k),)}}


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
    _only(data, {"terrain", "vehicle", "obstacle", "collision", "entity"}, path, "")

    terrain = _table(data, "terrain", path)
    _only(terrain, {"path", "up", *HEIGHTMAP_KEYS}, path, "[terrain]")
    terrain_path = _file(terrain, "path", base, path, "[terrain]") if "path" in terrain else None
    terrain_up = _choice(terrain, "up", UP_AXES + (None,), None, path, "[terrain]")
    if terrain_path is not None:
        terrain_path = TerrainPath(terrain_path, _heightmap(terrain, terrain_path, path))
    elif any(k in terrain for k in HEIGHTMAP_KEYS):
        key = next(k for k in HEIGHTMAP_KEYS if k in terrain)
        raise InputError(path, f"{key} describes a heightmap, but the scene names no [terrain] path",
                         where=f"[terrain] {key}")

    veh = _table(data, "vehicle", path)
    vehicle, mesh, mesh_placement = _vehicle_table(veh, base, path, "[vehicle]")
    entities = _entity_tables(data.get("entity", []), base, path)

    raw_obstacles = data.get("obstacle", [])
    if not isinstance(raw_obstacles, list):
        raise InputError(path, "obstacles are written [[obstacle]]", where="obstacle")
    obstacles = []
    names = set()
    for i, ob in enumerate(raw_obstacles):
        where = f"[[obstacle]] {i + 1}"
        if not isinstance(ob, dict):
            raise InputError(path, "must be a table", where=where)
        _only(ob, {"name", "path", "up", "position", "yaw_deg", "pitch_deg", "roll_deg", "scale"}, path, where)
        name = ob.get("name", f"obstacle{i + 1}")
        if not isinstance(name, str) or not name:
            raise InputError(path, "name must be a non-empty string", where=f"{where} name")
        if name in names:
            raise InputError(path, f"obstacle name {name!r} used twice", where=f"{where} name")
        names.add(name)
        if "path" not in ob:
            raise InputError(path, "an obstacle needs a path", where=f"{where} path")
        mesh_path = _file(ob, "path", base, path, where)
        if "position" not in ob:
            raise InputError(path, "an obstacle needs a position [x, y, z]: where the mesh's origin goes, in the "
                                   "terrain's coordinates (e.g. with a UTM terrain, eastings and northings)",
                             where=f"{where} position")
        position = ob["position"]
        if (not isinstance(position, list) or len(position) != 3 or not all(_finite(p) for p in position)):
            raise InputError(path, f"position must be three finite numbers [x, y, z], got {position!r}", where=f"{where} position")
        obstacles.append(ObstacleSpec(name, mesh_path,
                                      _choice(ob, "up", UP_AXES + (None,), None, path, where),
                                      tuple(float(p) for p in position),
                                      _angle(ob, "yaw_deg", path, where), _angle(ob, "pitch_deg", path, where),
                                      _angle(ob, "roll_deg", path, where), _scale(ob, "scale", path, where)))

    col = _table(data, "collision", path)
    _only(col, {"k", "aabb_levels", "split", "leaf_size"}, path, "[collision]")
    k = col.get("k", TREE_DEFAULTS["k"])
    if k not in KDOP_KS or isinstance(k, bool):
        raise InputError(path, f"k must be one of {', '.join(map(str, KDOP_KS))}, got {k!r}", where="[collision] k")
    levels = col.get("aabb_levels", TREE_DEFAULTS["aabb_levels"])
    if not isinstance(levels, int) or isinstance(levels, bool) or levels < 0:
        raise InputError(path, f"aabb_levels must be a whole number >= 0, got {levels!r}", where="[collision] aabb_levels")
    split = _choice(col, "split", SPLITS, TREE_DEFAULTS["split"], path, "[collision]")
    leaf = col.get("leaf_size", TREE_DEFAULTS["leaf_size"])
    if not isinstance(leaf, int) or isinstance(leaf, bool) or not 1 <= leaf <= 64:
        raise InputError(path, f"leaf_size must be a whole number from 1 to 64, got {leaf!r}", where="[collision] leaf_size")
    return Scene(path, terrain_path, terrain_up, vehicle, mesh, mesh_placement, obstacles,
                 CollisionSettings(int(k), int(levels), split, int(leaf)), entities)


VEHICLE_TABLE_KEYS = VEHICLE_KEYS | {"preset", "mesh", "mesh_up", "mesh_scale", "mesh_yaw_deg", "mesh_pitch_deg",
                                     "mesh_roll_deg"}


def _vehicle_table(veh: dict, base: str, path: str, where: str):
    """A vehicle described by a table of the scene ([vehicle] or an [[entity]]): (Vehicle, mesh path
    or None, MeshPlacement), every key checked."""
    _only(veh, VEHICLE_TABLE_KEYS | ({"id", "match"} if where.startswith("[[entity]]") else set()), path, where)
    preset = veh.get("preset", "t72")
    if not isinstance(preset, str) or preset.lower() not in PRESETS:
        raise InputError(path, f"unknown preset {preset!r}; choose one of {', '.join(PRESETS)}", where=f"{where} preset")
    overrides = {}
    for key in sorted(VEHICLE_KEYS & set(veh)):
        value = veh[key]
        if key == "fuel_drums":
            if not isinstance(value, bool):
                raise InputError(path, f"must be true or false, got {value!r}", where=f"{where} fuel_drums")
        elif isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(path, f"must be a number, got {value!r}", where=f"{where} {key}")
        # counts stay whole (a whole float is taken as one: 6.0 road wheels are 6)
        overrides[key] = value if key == "fuel_drums" else (
            int(value) if key == "road_wheels" and float(value).is_integer() else float(value))
    try:
        vehicle = vehicle_preset(preset, **overrides)
    except ValueError as exc:
        raise InputError(path, str(exc), where=where) from None
    mesh = _file(veh, "mesh", base, path, where) if "mesh" in veh else None
    loose = sorted(k for k in veh if k.startswith("mesh_")) if mesh is None else []
    if loose:
        raise InputError(path, f"{loose[0]} places the vehicle mesh, but the table names no mesh",
                         where=f"{where} {loose[0]}")
    placement = MeshPlacement(_choice(veh, "mesh_up", UP_AXES + (None,), None, path, where),
                              _scale(veh, "mesh_scale", path, where), _angle(veh, "mesh_yaw_deg", path, where),
                              _angle(veh, "mesh_pitch_deg", path, where), _angle(veh, "mesh_roll_deg", path, where))
    return vehicle, mesh, placement


def _entity_tables(raw, base: str, path: str) -> list:
    """The scene's [[entity]] tables: which vehicle an entity of an exercise is."""
    if not isinstance(raw, list):
        raise InputError(path, "entities are written [[entity]]", where="entity")
    out = []
    for i, table in enumerate(raw):
        where = f"[[entity]] {i + 1}"
        if not isinstance(table, dict):
            raise InputError(path, "must be a table", where=where)
        if ("id" in table) == ("match" in table):
            raise InputError(path, "give id (one entity) or match (a pattern of ids, * and ? wildcards): one of them",
                             where=where)
        key = "id" if "id" in table else "match"
        value = table[key]
        if not isinstance(value, str) or not value or any(c in value for c in ',"\''):
            raise InputError(path, f"{key} must be a non-empty text without commas or quotes, got {value!r}",
                             where=f"{where} {key}")
        vehicle, mesh, placement = _vehicle_table({k: v for k, v in table.items() if k not in ("id", "match")},
                                                  base, path, where)
        out.append(EntityVehicle(value if key == "id" else None, value if key == "match" else None, vehicle, mesh,
                                 placement))
    return out


def _heightmap(terrain: dict, terrain_path: str, path: str):
    """The HeightmapSpec of the [terrain] table's heightmap keys (None without any); checked
    here, naming the key (docs/formats.md, "[terrain]")."""
    from tankcd_cli.io.heightmap import HeightmapSpec, is_heightmap, parse_size

    given = [k for k in HEIGHTMAP_KEYS if k in terrain]
    if not given:
        return None
    if not is_heightmap(terrain_path):
        only = [k for k in given if k not in HeightmapSpec.SHARED]
        if only:
            raise InputError(path, f"{only[0]} describes a heightmap (PNG, RAW); {os.path.basename(terrain_path)} is "
                                   "none (a DEM raster or a store carries its own georeferencing)",
                             where=f"[terrain] {only[0]}")
        if not _is_dem_raster(terrain_path):  # crs, band: a raster's target CRS and band, as classify's options
            raise InputError(path, f"{given[0]} applies to a DEM raster (the CRS it is reprojected to, its band) or a "
                                   f"heightmap; {os.path.basename(terrain_path)} is neither (a store or a mesh keeps "
                                   "its own)", where=f"[terrain] {given[0]}")

    def number(key, positive=False, nonzero=False):
        value = terrain.get(key)
        if value is None:
            return None
        if not _finite(value) or (positive and value <= 0) or (nonzero and value == 0):
            what = "a positive number" if positive else "a finite number other than 0" if nonzero else "a finite number"
            raise InputError(path, f"{key} must be {what} (m), got {value!r}", where=f"[terrain] {key}")
        return float(value)

    def pair(key):
        value = terrain.get(key)
        if value is None:
            return None
        if not isinstance(value, list) or len(value) != 2 or not all(_finite(v) for v in value):
            raise InputError(path, f"{key} must be two finite numbers [a, b], got {value!r}", where=f"[terrain] {key}")
        return (float(value[0]), float(value[1]))

    z_range = pair("z_range")
    if z_range is not None:
        if z_range[0] >= z_range[1]:
            raise InputError(path, f"z_range must be [LOW, HIGH] with LOW < HIGH, got {list(z_range)}",
                             where="[terrain] z_range")
        both = [k for k in ("z_scale", "z_offset") if k in terrain]
        if both:
            raise InputError(path, f"z_range says the scale and the offset: give it or {both[0]}, not both",
                             where=f"[terrain] {both[0]}")
    crs = terrain.get("crs")
    if crs is not None and (not isinstance(crs, str) or not crs.strip()):
        raise InputError(path, f"crs must be a CRS (e.g. \"EPSG:32633\"), got {crs!r}", where="[terrain] crs")
    size = terrain.get("size")
    if size is not None:
        try:
            if isinstance(size, str):
                size = parse_size(size)
            elif isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                                                   for v in size):
                size = parse_size(f"{size[0]}x{size[1]}")
            else:
                raise ValueError(f"{size!r} is not \"COLSxROWS\" or [cols, rows]")
        except ValueError as exc:
            raise InputError(path, f"size: {exc}", where="[terrain] size") from None
    band = terrain.get("band")
    if band is not None and (not isinstance(band, int) or isinstance(band, bool) or band < 1):
        raise InputError(path, f"band must be a whole number from 1, got {band!r}", where="[terrain] band")
    return HeightmapSpec(spacing=number("spacing", positive=True), z_scale=number("z_scale", positive=True),
                         z_offset=number("z_offset"), z_range=z_range, origin=pair("origin"), crs=crs, size=size,
                         band=band)


def _is_dem_raster(terrain_path: str) -> bool:
    """Whether the terrain is a DEM raster (GDAL's, an ESRI grid), which --crs and --band apply to."""
    from tankcd_cli.io.h5 import is_hdf5
    from tankcd_cli.io.terrain_files import file_terrain_kind

    try:
        return not is_hdf5(terrain_path) and file_terrain_kind(terrain_path) in ("raster", "esri_ascii")
    except InputError:
        return False


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _angle(table, key, path, where) -> float:
    value = table.get(key, 0.0)
    if not _finite(value):
        raise InputError(path, f"{key} must be a finite number (degrees), got {value!r}", where=f"{where} {key}")
    return float(value)


def _scale(table, key, path, where) -> tuple:
    """A positive finite number (uniform) or [sx, sy, sz] of them, as (sx, sy, sz)."""
    value = table.get(key, 1.0)
    values = value if isinstance(value, list) else [value]
    if len(values) not in (1, 3) or not all(_finite(v) and v > 0 for v in values):
        raise InputError(path, f"{key} must be a positive finite number or three of them [sx, sy, sz], "
                               f"got {value!r}", where=f"{where} {key}")
    return tuple(float(v) for v in values) * (3 if len(values) == 1 else 1)


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
    if value not in options or (value is None and key in table):
        shown = ", ".join(o for o in options if o is not None)
        raise InputError(path, f"must be one of {shown}, got {value!r}", where=f"{where} {key}")
    return value


def _file(table, key, base, path, where):
    value = table[key]
    if not isinstance(value, str) or not value:
        raise InputError(path, f"must be a file path, got {value!r}", where=f"{where} {key}")
    full = value if os.path.isabs(value) else os.path.join(base, value)
    if not os.path.isfile(full):
        raise InputError(path, f"file not found: {value}", where=f"{where} {key}")
    return full
