"""Where any terrain is opened or classified, and the one place that decides mesh or DEM.

``terrain_kind`` names what a terrain input is: a store (by its HDF5 signature, then its root
attribute ``layout``), a DEM (an ESRI ASCII grid; a heightmap, PNG or RAW, as game engines write
them; or a raster GDAL reads: by the format given, the suffix, a folder of tiles or the file's
magic bytes) or a mesh (anything else, for the readers to judge). ``open_terrain`` gives the
surface of any of them, classifying on the fly what is not a store; ``classify_file`` writes
the store of any of them. Both ask ``terrain_kind``, so an input is a DEM to one exactly when it
is to the other.

A DEM becomes the grid layout (``grid/``), a mesh the mesh layout (``mesh/``). A heightmap needs
what its file does not say, a ``HeightmapSpec`` (``io/heightmap.py``: the post spacing, how its
values become heights, where it lies); a scene's terrain path carries the scene's (its
``heightmap`` attribute, ``scene.TerrainPath``), so whatever opens a scene's terrain reads it as
the scene says.

Set-up checks on a DEM (``SetupWarning``, which ``--strict`` makes bad input): posts wider than
half the vehicle's track length cannot resolve what the tracks feel (``grid/resolution.py``:
when a DEM is classified, and when a grid store is opened for a vehicle, so replay warns on
either); quantized heights are found and filtered when a DEM is classified
(``grid/classify.py``, ``grid/quantum.py``).
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from dataclasses import dataclass
from typing import Callable

from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.io.atomic import atomic_path
from tankcd_cli.io.h5 import is_hdf5
from tankcd_cli.names import AUTO_METHODS
from tankcd_cli.terrain.grid.resolution import coarse_posts
from tankcd_cli.terrain.grid.store import open_grid
from tankcd_cli.terrain.mesh.store import MeshStore, read_mesh_store, write_mesh_store
from tankcd_cli.terrain.mesh.surface import MeshSurface
from tankcd_cli.terrain.regions import Thresholds
from tankcd_cli.terrain.store import read_attrs, store_layout
from tankcd_cli.terrain.surface import Surface
from tankcd_cli.vehicle import Vehicle, vehicle_preset

# The readers and classifiers of DEMs and meshes (grid.sources, grid.classify, mesh.classify,
# io.terrain_files: rasters, heightmaps, mesh formats) are imported in the branches that use
# them: a replay over a store, the common case, loads none of them (about 0.1 s of start-up).

DEM_KINDS = ("grid_store", "esri_ascii", "raster", "heightmap")  # read as DEM sources (grid/sources.py)
TERRAIN_KINDS = ("grid_store", "mesh_store", "esri_ascii", "raster", "heightmap", "mesh")


class OptionError(ValueError):
    """An option that does not apply to the input it was given with (the command line's usage
    error, exit 2): --up y for a DEM, --crs for a mesh, ..."""


def terrain_kind(path: str, fmt: str | None = None) -> str:
    """What the terrain input ``path`` is, one of ``TERRAIN_KINDS``.

    fmt : the format named by the user (a suffix such as "asc", "tif", "obj", or "h5" for a
        store), which overrides what the file says; None: the file decides. Standard input
        ("-") is a mesh unless ``fmt`` names a DEM.
    A store is recognised by its signature and its root attribute ``layout``; an HDF5 file
    that is not a terrain store is an InputError.
    """
    f = (fmt or "").lower()
    if f == "h5" or (not f and path != "-" and is_hdf5(path)):  # first: a store needs no other reader
        return "grid_store" if store_layout(path) == "grid" else "mesh_store"
    from tankcd_cli.io.terrain_files import file_terrain_kind

    return file_terrain_kind(path, f)


def heightmap_of(path: str, heightmap=None):
    """The HeightmapSpec to read ``path`` with: the one given, else the one a scene's terrain
    path carries, else None."""
    return heightmap if heightmap is not None else getattr(path, "heightmap", None)


def _refuse_heightmap_options(kind: str, heightmap) -> None:
    """Heightmap options given for an input that is no heightmap: an OptionError."""
    given = [k for k in (heightmap.given() if heightmap is not None else []) if k not in heightmap.SHARED]
    if given:
        label = heightmap.LABELS[given[0]]
        what = "a mesh keeps its coordinates" if kind in ("mesh", "mesh_store") else \
            "a DEM raster or a store carries its own georeferencing and heights"
        raise OptionError(f"{label} applies to heightmaps (PNG, RAW); {what}")


def open_dem(path: str, fmt: str | None = None, band: int | None = None, crs: str | None = None, heightmap=None):
    """The DEM source of ``path`` (``grid.sources``: ``grid``, ``info``, ``read`` by window; a
    context manager), or None when ``terrain_kind`` calls it a mesh or a mesh store.
    heightmap : a heightmap's HeightmapSpec (default: the one ``path`` carries, ``heightmap_of``)"""
    kind = terrain_kind(path, fmt)
    if kind not in DEM_KINDS:
        return None
    from tankcd_cli.terrain.grid.sources import open_source

    return open_source(kind, str(path), fmt=fmt, band=band, crs=crs, heightmap=heightmap_of(path, heightmap))


@dataclass(frozen=True)
class OpenedTerrain:
    """A terrain opened for queries.

    surface : the :class:`~tankcd_cli.terrain.surface.Surface` every query runs on
    layout : "grid" (a DEM, read by window from a grid store) or "mesh"
    store_path : the store on disk the surface reads (a grid store: read by window while the
        surface lives; a mesh store: read whole), or None for a mesh classified in memory
    mesh_store : the :class:`~tankcd_cli.terrain.mesh.store.MeshStore` behind a mesh surface
        (read from ``store_path`` or classified here), else None
    source : the input path as given
    classified : whether this call classified the terrain (False: it read a store)
    """

    surface: Surface
    layout: str
    store_path: str | None
    mesh_store: MeshStore | None
    source: str
    classified: bool


def open_terrain(path: str, up: str | None = None, fmt: str | None = None, vehicle: Vehicle | None = None,
                 progress: Callable[[str], None] | None = None, cache: bool = False,
                 heightmap=None) -> OpenedTerrain:
    """The surface of any terrain input: a store is opened (a grid store for windowed reads:
    nothing of its rasters is read until a query needs it); a DEM is classified tile by tile
    into a grid store (beside it as ``<stem>.h5`` with ``cache``, else a temporary one removed
    at exit); a mesh is classified in memory (and, with ``cache``, saved as ``<stem>.h5``). A
    cached store is used again when it names the input's SHA-256 (and a heightmap's reading).

    up : the mesh's up axis ("z", "y"; None: the format's convention)
    fmt : the input's format when its name does not say (see ``terrain_kind``)
    vehicle : the :class:`~tankcd_cli.vehicle.Vehicle` whose footprint classifies (default T-72)
    progress : called with each stage's description
    heightmap : a heightmap's HeightmapSpec (default: the one ``path`` carries, ``heightmap_of``)
    A DEM or grid store whose posts are too coarse for the vehicle warns (``grid.resolution``).
    """
    say = progress or (lambda stage: None)
    kind = terrain_kind(path, fmt)
    heightmap, path = heightmap_of(path, heightmap), str(path)  # a plain path from here on
    if kind != "heightmap":
        _refuse_heightmap_options(kind, heightmap)
    if kind == "grid_store":  # the common case
        say(f"opening grid store {path}")
        surface = open_grid(path)
        if vehicle is not None:
            coarse_posts(surface.grid, vehicle, path)
        return OpenedTerrain(surface, "grid", path, None, path, False)

    if kind == "mesh_store":
        say(f"reading terrain store {path}")
        store = read_mesh_store(path)
        return OpenedTerrain(MeshSurface.from_store(store), "mesh", path, store, path, False)
    cached = os.path.splitext(path)[0] + ".h5"
    if kind in DEM_KINDS:
        from tankcd_cli.terrain.grid.sources import open_source

        # a raster takes the CRS and band a scene's [terrain] table names (HeightmapSpec.SHARED)
        crs, band = (heightmap.crs, heightmap.band) if kind != "heightmap" and heightmap is not None else (None, None)
        return _open_dem(open_source(kind, path, fmt=fmt, crs=crs, band=band, heightmap=heightmap), path,
                         cached if cache else None, vehicle, say)
    from tankcd_cli.terrain.mesh.classify import classify_mesh, read_mesh

    raw = read_mesh(path, up=up, fmt=fmt)
    if cache and os.path.exists(cached) and is_hdf5(cached):
        if read_attrs(cached).get("source_sha256") == raw.sha256:
            say(f"reading cached store {cached}")
            store = read_mesh_store(cached)
            return OpenedTerrain(MeshSurface.from_store(store), "mesh", cached, store, path, False)
    say(f"classifying {path} on the fly")
    store = classify_mesh(raw, vehicle=vehicle, progress=say)
    if cache:
        with atomic_path(cached, ".h5") as tmp:
            write_mesh_store(tmp, store)
        say(f"cached the store as {cached}")
    return OpenedTerrain(MeshSurface.from_store(store), "mesh", cached if cache else None, store, path, True)


def _open_dem(dem, path: str, cached: str | None, vehicle, say) -> OpenedTerrain:
    """A DEM classified into a grid store (``cached``, or a temporary file) and opened."""
    from tankcd_cli.terrain.grid.classify import classify_dem

    with dem:
        if cached and os.path.exists(cached) and is_hdf5(cached):
            a = read_attrs(cached)
            if a.get("layout") == "grid" and a.get("source_sha256") == dem.info.sha256 \
                    and a.get("heightmap", "") == dem.info.heightmap and a.get("crs_name") == dem.grid.crs_name:
                say(f"reading cached store {cached}")
                surface = open_grid(cached)
                coarse_posts(surface.grid, vehicle or vehicle_preset("t72"), dem.info.source)
                return OpenedTerrain(surface, "grid", cached, None, path, False)
        if cached:
            say(f"classifying {dem.info.source} into {cached}")
            with atomic_path(cached, ".h5") as tmp:
                classify_dem(dem, tmp, vehicle=vehicle)
            return OpenedTerrain(open_grid(cached), "grid", cached, None, path, True)
        folder = tempfile.mkdtemp(prefix="tankcd-")
        target = os.path.join(folder, "terrain.h5")
        atexit.register(_remove_tree, folder, os.getpid())
        say(f"classifying {dem.info.source} on the fly")
        classify_dem(dem, target, vehicle=vehicle)
        return OpenedTerrain(open_grid(target), "grid", target, None, path, True)


def _remove_tree(folder: str, owner: int) -> None:
    if os.getpid() == owner:  # a forked worker leaves the parent's files alone
        shutil.rmtree(folder, ignore_errors=True)


@dataclass(frozen=True)
class ClassifiedFile:
    """What ``classify_file`` wrote.

    layout : "grid" or "mesh"
    source : the input's name as the store records it
    output : the store's path ("-": standard output)
    method : the curvature method used
    attrs : the store's root attributes
    grid : the DEM's PostGrid (grid layout), else None
    mesh_store : the MeshStore written (mesh layout), else None
    """

    layout: str
    source: str
    output: str
    method: str
    attrs: dict
    grid: PostGrid | None = None
    mesh_store: MeshStore | None = None


def classify_file(path: str, output: str, method: str = "auto", up: str | None = None, fmt: str | None = None,
                  vehicle: Vehicle | None = None, thresholds: Thresholds | None = None, crs: str | None = None,
                  band: int | None = None, tile=None,
                  jobs: int | None = None, scheduler: str | None = None,
                  progress: Callable[[str], None] | None = None,
                  tile_progress: Callable[[int, int, int, float], None] | None = None,
                  on_grid: Callable | None = None,
                  before_commit: Callable[[str, ClassifiedFile], None] | None = None,
                  heightmap=None) -> ClassifiedFile:
    """Classify any terrain input into a store at ``output`` (written under a temporary name and
    renamed when complete): a DEM tile by tile into the grid layout, a mesh (or a mesh store,
    classified again) into the mesh layout; ``terrain_kind`` decides which.

    method : "auto" (``names.AUTO_METHODS``: grid on a DEM, jet on a mesh), "grid" (DEMs only),
        "cotan", "sphere", "jet"
    up, fmt : the mesh's up axis, the input's format (see ``open_terrain``)
    vehicle, thresholds : whose footprint averages, and the class boundaries (default: derived)
    crs, band, tile, jobs, scheduler : DEMs only: the metric CRS to warp to (a heightmap's: the CRS
        it is in), the raster band (a PNG's channel), posts per tile side (or (rows, cols)),
        worker threads, a Dask scheduler's address
    heightmap : a heightmap's HeightmapSpec (default: the one ``path`` carries); its options given
        for any other input are an OptionError
    progress : a mesh's stages, as ``open_terrain``'s
    tile_progress(done, total, posts, seconds) : a DEM's tiles
    on_grid(grid, info) : a DEM's PostGrid and DemSourceInfo, once it is open, before any work
    before_commit(tmp, classified) : called with the complete store under its temporary name and
        what this returns, before the store is renamed onto ``output`` (a map of it drawn there
        fails with it)
    An option that does not apply to the input is an :class:`OptionError`.
    """
    kind = terrain_kind(path, fmt)
    heightmap, path = heightmap_of(path, heightmap), str(path)  # a plain path from here on
    if kind != "heightmap":
        _refuse_heightmap_options(kind, heightmap)
    if kind in DEM_KINDS:
        from tankcd_cli.terrain.grid.sources import open_source

        dem = open_source(kind, path, fmt=fmt, band=band, crs=crs, heightmap=heightmap)
        with dem:
            if up not in (None, "z"):
                raise OptionError("--up y makes no sense for a DEM (grids are z-up)")
            spec = None
            if scheduler:
                if path == "-":
                    raise OptionError("--scheduler needs a DEM path the workers can read, not standard input")
                spec = (kind, os.path.abspath(path), fmt, band, crs, heightmap)
            method = AUTO_METHODS["dem"] if method == "auto" else method
            return _classify_dem(dem, output, method, vehicle, thresholds, tile, jobs, scheduler, spec,
                                 tile_progress, on_grid, before_commit)
    if scheduler:
        raise OptionError("--scheduler applies to DEMs; a mesh is classified in this process")
    if crs or band:
        raise OptionError("--crs and --band apply to DEM rasters; meshes keep their coordinates")
    for label, value in (("--tile", tile), ("--jobs", jobs)):
        if value is not None:
            raise OptionError(f"{label} applies to DEM rasters, classified tile by tile; a mesh is classified whole")
    if method == "grid":
        raise OptionError("--method grid needs a DEM; meshes take cotan, sphere or jet")
    method = AUTO_METHODS["mesh"] if method == "auto" else method
    from tankcd_cli.terrain.mesh.classify import classify_mesh, raw_terrain_of, read_mesh

    raw = raw_terrain_of(read_mesh_store(path), path) if kind == "mesh_store" else read_mesh(path, up=up, fmt=fmt)
    store = classify_mesh(raw, method=method, vehicle=vehicle, thresholds=thresholds, progress=progress)
    if progress:
        progress(f"writing {output}")
    done = ClassifiedFile("mesh", raw.source, output, method, store.attrs, None, store)
    with atomic_path(output, ".h5") as tmp:
        write_mesh_store(tmp, store)
        if before_commit:
            before_commit(tmp, done)
    return done


def _classify_dem(dem, output, method, vehicle, thresholds, tile, jobs, scheduler, spec, tile_progress, on_grid,
                  before_commit) -> ClassifiedFile:
    from tankcd_cli.terrain.grid.classify import classify_dem
    from tankcd_cli.terrain.grid.tiled_classify import DEFAULT_TILE

    if on_grid:
        on_grid(dem.grid, dem.info)
    with atomic_path(output, ".h5") as tmp:
        attrs = classify_dem(dem, tmp, method=method, vehicle=vehicle, thresholds=thresholds,
                             tile=DEFAULT_TILE if tile is None else tile, jobs=jobs, progress=tile_progress,
                             scheduler=scheduler, spec=spec)
        done = ClassifiedFile("grid", dem.info.source, output, method, attrs, dem.grid, None)
        if before_commit:
            before_commit(tmp, done)
    return done

