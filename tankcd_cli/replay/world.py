"""The world a replay runs in, resolved once: the terrain, the vehicle, the scene and what its
effects need (obstacle trees, the vehicle's moving parts).

``WorldSpec`` says what the world is made of in plain text (paths and names), so that it travels
to a fleet's worker processes or a Dask cluster and is loaded there; ``load_world`` (or
``WorldSpec.load``) is the one place a scene or the command line's flags become a ``World``.
Only what the scene's effects call for is loaded: a scene without obstacles loads no tree.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Callable

from tankcd_cli.collision.obstacles import body_of, load_obstacles, scene_vehicle_body
from tankcd_cli.errors import InputError, warn
from tankcd_cli.replay.effects import Effects, effects_for  # noqa: F401 (Effects: the world's, re-exported)
from tankcd_cli.scene import CollisionSettings, MeshPlacement, load_scene
from tankcd_cli.terrain.open import classify_file, open_terrain, terrain_kind
from tankcd_cli.vehicle import Vehicle, vehicle_preset


@dataclass(frozen=True)
class WorldSpec:
    """A world as text: a scene, or a terrain with a vehicle preset.

    scene : the scene TOML (it names the terrain and the vehicle), or None
    terrain : any terrain input (a store, a DEM, a mesh), when there is no scene
    vehicle : the vehicle preset without a scene ("t72", "t55", "m1")
    up : the up axis of a mesh terrain without a scene (None: the format's convention)
    cache : keep a terrain classified on the fly as a store beside it, and reuse it
    store : a store the terrain was already classified into (a fleet classifies once for all)
    """

    scene: str | None = None
    terrain: str | None = None
    vehicle: str = "t72"
    up: str | None = None
    cache: bool = False
    store: str | None = None

    def __post_init__(self):
        if (self.scene is None) == (self.terrain is None) and not (self.scene is None and self.store is not None):
            raise ValueError("a world needs a scene or a terrain (one of them)")

    def load(self, progress: Callable[[str], None] | None = None) -> "World":
        return load_world(self, progress)

    def terrain_input(self) -> tuple[str | None, str | None]:
        """The terrain input and its up axis, from the scene or the spec (no terrain file is read)."""
        if self.scene is not None:
            scene = load_scene(self.scene)
            return scene.terrain_path, scene.terrain_up
        return self.terrain, self.up


@dataclass
class VehicleKind:
    """One kind of vehicle in the world: the scene's [vehicle] (index 0) or an [[entity]] table's.

    index : 0 the default vehicle, k the k-th [[entity]] table; label : how ``info`` names it
    vehicle : its dimensions; mesh, placement : its shape's file (None: generated) and placement
    body : its moving parts (``collision.vehicle_body.VehicleBody``), built on first use (obstacle
        and vehicle checks need it)
    """

    index: int
    label: str
    vehicle: Vehicle
    mesh: str | None = None
    placement: object = None
    settings: object = None
    _body: object = None

    @property
    def body(self):
        if self._body is None:
            self._body = body_of(self.vehicle, self.mesh, self.placement or MeshPlacement(),
                                 self.settings or CollisionSettings())
        return self._body


@dataclass
class World:
    """A loaded world.

    terrain : the opened terrain (``terrain.open.OpenedTerrain``: its surface, layout, store)
    vehicle : the vehicle replayed
    scene : the scene (None with a bare terrain)
    obstacles : the obstacles' world trees (``collision.obstacles.Obstacle``), loaded with the world
    body : the vehicle's moving parts (``collision.vehicle_body.VehicleBody``), when obstacles need it
    spec : what it was loaded from
    kinds : the kinds of vehicle an exercise's entities are (``VehicleKind``: the default first)
    """

    terrain: object
    vehicle: Vehicle
    scene: object = None
    obstacles: list = field(default_factory=list)
    body: object = None
    spec: WorldSpec | None = None
    kinds: list = field(default_factory=list)

    def __post_init__(self):
        if not self.kinds:
            sc = self.scene
            self.kinds = [VehicleKind(0, "[vehicle]", self.vehicle, sc.vehicle_mesh if sc else None,
                                      sc.vehicle_mesh_placement if sc else None, sc.collision if sc else None,
                                      self.body)]
            for k, table in enumerate(sc.entities if sc is not None else []):
                self.kinds.append(VehicleKind(k + 1, f"[[entity]] {table.label}", table.vehicle, table.mesh,
                                              table.mesh_placement, sc.collision))
        self._kind_of: dict = {}

    def kind_of(self, entity: str) -> int:
        """The index of the kind of vehicle an entity is (the first [[entity]] table naming it, else 0)."""
        k = self._kind_of.get(entity)
        if k is None:
            k = self._kind_of[entity] = self.scene.entity_vehicle(entity) if self.scene is not None else 0
        return k

    @property
    def surface(self):
        return self.terrain.surface

    @property
    def crs(self) -> str:
        """The terrain's CRS (WKT; empty for a local grid or a mesh, which carry none)."""
        crs = getattr(self.terrain.surface, "crs", None)
        if crs is None and self.terrain.mesh_store is not None:
            crs = self.terrain.mesh_store.attrs.get("crs", "")
        return crs or ""

    def effects(self, turret_moves: bool, kind: int = 0) -> Effects:
        """The effects of this world for a trajectory whose turret or gun moves or not, for a kind of
        vehicle (the drums are the vehicle's)."""
        return effects_for(self.kinds[kind].vehicle, bool(self.obstacles), turret_moves)


def load_world(spec: WorldSpec, progress: Callable[[str], None] | None = None) -> World:
    """The world of ``spec``: the scene read and checked, the terrain opened (classified on the fly
    when it is no store), and, for a scene with obstacles, their trees and the vehicle's parts."""
    scene = None
    if spec.scene is not None:
        scene = load_scene(spec.scene)
        vehicle, terrain, up = scene.vehicle, scene.required_terrain(), scene.terrain_up
    else:
        vehicle, terrain, up = vehicle_preset(spec.vehicle), spec.terrain, spec.up
    opened = open_terrain(spec.store or terrain, up=up, vehicle=vehicle, progress=progress, cache=spec.cache)
    world = World(opened, vehicle, scene, spec=spec)
    if scene is not None and scene.obstacles:
        world.obstacles = load_obstacles(scene, cache=True, progress=progress)
        warn_obstacles_beside(scene.path, world.obstacles, opened.surface)
        world.body = world.kinds[0]._body = scene_vehicle_body(scene)
    return world


def warn_obstacles_beside(source: str, obstacles: list, surface) -> None:
    """A warning for each obstacle whose bounds miss the terrain's: it can never be hit (the
    likeliest cause, a position without the terrain's offset, such as a UTM easting)."""
    lo, hi = surface.bounds()
    for ob in obstacles:
        if ob.hi[0] < lo[0] or ob.lo[0] > hi[0] or ob.hi[1] < lo[1] or ob.lo[1] > hi[1]:
            warn(source, f"obstacle {ob.name!r} lies off the terrain: it spans x {ob.lo[0]:.1f} to {ob.hi[0]:.1f}, "
                         f"y {ob.lo[1]:.1f} to {ob.hi[1]:.1f}; the terrain x {lo[0]:.1f} to {hi[0]:.1f}, "
                         f"y {lo[1]:.1f} to {hi[1]:.1f} (is its position in the terrain's coordinates?)")


def world_inputs(spec: WorldSpec) -> dict:
    """The files a world reads, labelled as the command line names them (for output clashes)."""
    files = {"--scene": spec.scene, "--terrain": spec.terrain}
    if spec.scene is not None:
        scene = load_scene(spec.scene)
        files.update({"the scene's terrain": scene.terrain_path, "the scene's vehicle mesh": scene.vehicle_mesh})
        for ob in scene.obstacles:
            files[f"obstacle {ob.name!r}"] = ob.path
    return {k: v for k, v in files.items() if v is not None}


def classify_once(spec: WorldSpec, out_dir: str, progress: Callable[[str], None] | None = None) -> WorldSpec:
    """The spec with its terrain as a store: a mesh or DEM is classified once (into ``out_dir``), in
    a child process started afresh (spawned), so that no compiled kernel has started threads in
    this process before it forks its workers. A store, or a spec with one, is returned as it is."""
    import dataclasses
    import multiprocessing

    terrain, up = spec.terrain_input()
    if spec.store is not None or terrain is None or terrain_kind(terrain) in ("grid_store", "mesh_store"):
        return spec
    store = os.path.join(out_dir, ".fleet-terrain.h5")
    (progress or (lambda s: None))(f"classifying {terrain} once for the fleet")
    vehicle = spec.vehicle
    if spec.scene is not None:
        vehicle = load_scene(spec.scene).vehicle
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        error = pool.apply(_classify_in_child, (terrain, store, up, vehicle))
    if error is not None:
        raise InputError(*error)
    return dataclasses.replace(spec, store=store)


def _classify_in_child(terrain: str, store: str, up, vehicle) -> tuple | None:
    """In the spawned child: classify, or say what was wrong with the input (source, what, where)."""
    try:
        classify_file(terrain, store, up=up, vehicle=vehicle if isinstance(vehicle, Vehicle) else vehicle_preset(vehicle))
    except InputError as exc:
        return exc.source, exc.what, exc.where
    return None
