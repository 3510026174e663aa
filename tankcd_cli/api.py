"""tankcd as a library: the functions the command line calls, for notebooks and simulators.

```python
from tankcd_cli import api

terrain = api.open_terrain("battlefield.h5")           # a store, or any terrain input (classified on the fly)
poses = api.place(terrain, x, y, yaw_deg)              # dict of arrays keyed by the poses CSV's columns
poses, events = api.replay("patrol.csv", scene="scene.toml")     # or terrain=...; or a dict of arrays
summary = api.replay_to_files("patrol.csv", poses="poses.csv", events="events.jsonl", scene="scene.toml")
# (poses="poses.parquet", events="events.parquet": Parquet, with pip install 'tankcd[parquet]')
store = api.classify("dem.tif", "dem.h5")              # the terrain store, as `tankcd classify` writes it
events = api.collide("scene.toml", poses)              # the vehicle at given poses against the obstacles
envelope = api.gun_envelope("t72")                     # the lowest safe gun elevation per turret azimuth
api.report("poses.csv", "events.jsonl", "review.html", scene="scene.toml")  # or .geojson, .czml, .pcap
```

Conventions are the command line's (docs/formats.md): metres, seconds, degrees in and out (radians
only inside); x east, y north, z up in the terrain's CRS; ``yaw_deg`` counter-clockwise from east;
REP 103 attitudes. Arrays are numpy arrays (N,); a scalar where an array is taken is one row.
Bad input raises ``tankcd_cli.errors.InputError`` (the command line's exit 3) with one line naming
what is wrong; set-up slips are ``tankcd_cli.errors.SetupWarning`` warnings (turn them into errors
with ``warnings.simplefilter("error", SetupWarning)``, the command line's ``--strict``).

Importing this module imports numpy only; each function imports what it uses.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["open_terrain", "classify", "place", "load_world", "replay", "replay_to_files", "replay_windows",
           "replay_fleet", "replay_mode", "run_replay", "export_trajectory", "collide", "gun_envelope", "vehicle", "trajectory_chunks", "describe", "report"]

TRAJECTORY_COLUMNS = ("t", "x", "y", "yaw_deg", "turret_deg", "gun_deg")


def vehicle(vehicle="t72", **dimensions):
    """A :class:`~tankcd_cli.vehicle.Vehicle`: a preset by name ("t72", "t55", "m1"), or a
    ``Vehicle`` as it is, with any dimension overridden (metres; ``fuel_drums`` a bool)."""
    return _as_vehicle(vehicle, **dimensions)


def _as_vehicle(vehicle, **dimensions):
    import dataclasses

    from tankcd_cli.vehicle import Vehicle, vehicle_preset

    if isinstance(vehicle, Vehicle):
        return dataclasses.replace(vehicle, **dimensions) if dimensions else vehicle
    try:
        return vehicle_preset(str(vehicle), **dimensions)
    except ValueError as exc:
        from tankcd_cli.errors import InputError

        raise InputError("vehicle", str(exc)) from None


def open_terrain(path: str, up: str | None = None, vehicle="t72", cache: bool = False,
                 progress: Callable[[str], None] | None = None):
    """A terrain opened for queries (``terrain.open.OpenedTerrain``: ``.surface``, ``.layout``
    "grid" or "mesh", ``.store_path``): a store is opened for windowed reads; a DEM or a mesh is
    classified on the fly (with ``cache``, into ``<stem>.h5`` beside it, reused while the input's
    SHA-256 matches). ``up``: a mesh's up axis ("z" or "y"; None: the format's convention);
    ``vehicle``: whose footprint sizes the classes of a terrain classified here."""
    from tankcd_cli.terrain.open import open_terrain as _open

    return _open(path, up=up, vehicle=_as_vehicle(vehicle), progress=progress, cache=cache)


def classify(terrain: str, output: str | None = None, method: str = "auto", up: str | None = None, vehicle="t72",
             thresholds=None, fmt: str | None = None, crs: str | None = None, band: int | None = None,
             tile: int | None = None, jobs: int | None = None, scheduler: str | None = None,
             progress: Callable[[str], None] | None = None, **hooks):
    """Classify any terrain input into a store (default: ``terrain``'s stem + ``.h5``), as
    ``tankcd classify`` does: mean curvature per vertex or post, then flat / general / uneven
    classes. Returns ``terrain.open.ClassifiedFile`` (``.output``, ``.layout``, ``.attrs`` with
    the area shares). ``thresholds``: (flat, uneven) in 1/m (or a ``terrain.regions.Thresholds``),
    overriding the vehicle's. An option that does not apply to the input (``up="y"`` for a DEM,
    ``tile`` for a mesh) is a ``terrain.open.OptionError`` (a ValueError). ``hooks``:
    ``classify_file``'s ``tile_progress``, ``on_grid``, ``before_commit`` (what the command line
    draws and reports). ``fmt``: the input's format where its name does not say (``-``: stdin)."""
    import os

    from tankcd_cli.terrain.open import classify_file
    from tankcd_cli.terrain.regions import Thresholds

    if output is None:
        output = os.path.splitext(terrain)[0] + ".h5"
    limits = thresholds
    if thresholds is not None and not isinstance(thresholds, Thresholds):
        limits = Thresholds(float(thresholds[0]), float(thresholds[1]), derivation="given by the caller")
    return classify_file(terrain, output, method=method, up=up, fmt=fmt, vehicle=_as_vehicle(vehicle),
                         thresholds=limits, crs=crs, band=band, tile=tile, jobs=jobs, scheduler=scheduler,
                         progress=progress, **hooks)


def place(terrain, x, y, yaw_deg, matcher: str = "auto", vehicle="t72", escalate: bool | None = None,
          tolerance: float | None = None, attitude_tolerance: float | None = None) -> dict:
    """Place the vehicle on ``terrain`` (``open_terrain``'s, or a path) with its footprint centre at
    (x, y) m heading ``yaw_deg``: a dict of arrays keyed by the poses CSV's columns (``step`` counts
    from 0, ``t`` is NaN; region, matcher and status as names; NaN where a row has no pose).

    matcher : ``auto`` (by the region class under the footprint, escalated by the reference's
        certificate), ``two_point``, ``four_point``, ``six_point``, ``wheel_stations``, ``reference``
    escalate, tolerance, attitude_tolerance : as ``replay``'s (None: escalate ``auto`` only, the
        tolerances the defaults: the height from the vehicle, the attitude 0.5 deg)
    """
    from tankcd_cli.io.poses_csv import pose_columns
    from tankcd_cli.matching.match import match
    from tankcd_cli.names import MATCHER_CHOICES

    if matcher not in MATCHER_CHOICES:
        raise ValueError(f"unknown matcher {matcher!r}; choose one of {', '.join(MATCHER_CHOICES)}")
    _check_tolerances(tolerance, attitude_tolerance)
    if isinstance(terrain, str):
        terrain = open_terrain(terrain, vehicle=vehicle)
    x, y, yaw = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in (x, y, yaw_deg)))
    poses = match(terrain.surface, _as_vehicle(vehicle), x, y, np.radians(yaw), matcher=matcher,
                  escalate=escalate, tolerance=tolerance, attitude_tolerance=attitude_tolerance)
    return pose_columns(np.arange(len(x)), np.full(len(x), np.nan), poses)


def load_world(scene: str | None = None, terrain: str | None = None, vehicle: str = "t72", up: str | None = None,
               cache: bool = False, progress: Callable[[str], None] | None = None):
    """The world a replay runs in (``replay.world.World``), loaded once: from a scene (its terrain,
    vehicle, obstacles) or a terrain and a vehicle preset. Give it to ``replay`` as ``world=`` to
    replay many trajectories without loading the terrain and trees again."""
    from tankcd_cli.replay.world import WorldSpec

    return WorldSpec(scene=scene, terrain=terrain, vehicle=vehicle, up=up, cache=cache).load(progress)


def _world(world, scene, terrain, vehicle, up, cache, progress):
    if world is not None:
        return world
    if (scene is None) == (terrain is None):
        raise ValueError("give scene= or terrain= (one of them), or world=")
    return load_world(scene, terrain, vehicle, up, cache, progress)


def _check_tolerances(tolerance, attitude_tolerance) -> None:
    """The certificate's tolerances, when given, are positive numbers (NaN is not)."""
    if attitude_tolerance is not None and not attitude_tolerance > 0:
        raise ValueError(f"attitude_tolerance must be positive (deg), not {attitude_tolerance!r}")
    if tolerance is not None and not tolerance > 0:
        raise ValueError(f"tolerance must be positive (m), not {tolerance!r}")


def _options(matcher, escalate, tolerance, discrete, attitude_tolerance=None, gates=True):
    from tankcd_cli.names import MATCHER_CHOICES
    from tankcd_cli.replay.records import ReplayOptions

    if matcher not in MATCHER_CHOICES:
        raise ValueError(f"unknown matcher {matcher!r}; choose one of {', '.join(MATCHER_CHOICES)}")
    _check_tolerances(tolerance, attitude_tolerance)
    return ReplayOptions(matcher=matcher, escalate=escalate, tolerance=tolerance,
                         attitude_tolerance=attitude_tolerance, continuous=not discrete, gates=bool(gates))


def replay(trajectory, scene: str | None = None, terrain: str | None = None, vehicle: str = "t72",
           matcher: str = "auto", discrete: bool = False, escalate: bool | None = None,
           tolerance: float | None = None, world=None, up: str | None = None, cache: bool = False,
           attitude_tolerance: float | None = None, fmt: str | None = None, gates: bool = True):
    """Replay a trajectory and keep the results in memory: (poses, events).

    trajectory : a path (a trajectory CSV, a geographic CSV, GPX or a DIS capture: the command
        line's inputs), a list of paths replayed as one exercise (``--together``: each file an
        entity named after its stem, or its own entities), or a dict of arrays with ``t``, ``x``,
        ``y``, ``yaw_deg`` and optionally ``turret_deg``, ``gun_deg`` (metres, seconds, degrees;
        ``t`` never decreasing) and ``entity`` (each row's vehicle: an exercise, rows in any order);
        or with ``lon``, ``lat`` (WGS 84 degrees) in place of ``x``, ``y`` and ``heading_deg`` (a
        compass bearing), ``yaw_deg`` (from true east) or neither (the track's, warned), converted
        to the terrain's CRS as a geographic CSV is (see ``trajectory_chunks``)
    scene or terrain (with ``vehicle``) : the world, or ``world`` from ``load_world``
    discrete : check the rows only (default: every effect along the motion between rows too)
    escalate : check key-point poses against the reference's certificate and solve those that
        fail it by the reference (None: for ``auto`` only)
    tolerance, attitude_tolerance : the certificate's height tolerance at the footprint's corners
        (m; None: half the footprint's shorter side times tan 1 deg) and its attitude tolerance
        (deg; None: 0.5): a key-point pose farther than either from a plane the certificate
        finds is escalated
    fmt : the path's (or paths') format, csv, gpx, pcap or pcapng, where neither name nor content says
    gates : let the conservative gates skip exact work they prove can find nothing (False: the exact
        work everywhere; the same poses and events, byte for byte)
    Returns poses, a dict of arrays keyed by the poses CSV's columns, and events, a list of dicts
    as the events JSON Lines' lines (``between``: a contact that began between rows).
    """
    from tankcd_cli.replay.run import replay_rows

    trajectory = _with_format(trajectory, fmt)
    w = _world(world, scene, terrain, vehicle, up, cache, None)
    return replay_rows(w, _chunks(trajectory, w),
                       _options(matcher, escalate, tolerance, discrete, attitude_tolerance, gates))


def _with_format(trajectory, fmt: str | None):
    """A path, or each of several, carrying the format given (``io.input_formats.TrajectoryPath``)."""
    from tankcd_cli.io.input_formats import with_format

    if fmt is None or not isinstance(trajectory, (str, list, tuple)):
        return trajectory
    if isinstance(trajectory, str):
        return with_format(trajectory, fmt)
    return [with_format(str(p), fmt) for p in trajectory]


def _chunks(trajectory, world):
    """A replay's input: a path as it is (the reader takes it), several paths as one exercise
    (their rows merged in time, each file an entity or its own entities), or a dict of arrays."""
    if isinstance(trajectory, str):
        return trajectory
    if isinstance(trajectory, (list, tuple)):
        from tankcd_cli.io.trajectory import merged_trajectories

        paths = [p if isinstance(p, str) else str(p) for p in trajectory]
        return _Reread(lambda: merged_trajectories(paths, crs=world.crs))
    return _Reread(lambda: trajectory_chunks(trajectory, crs=world.crs),
                   first=trajectory_chunks(trajectory, crs=world.crs))  # checked here


class _Reread:
    """Chunks that can be read again (each ``iter`` a new pass: ``replay.run.in_time_order`` reads an
    exercise's times first); ``first``: the iterator the first pass takes."""

    def __init__(self, make, first=None):
        self.make = make
        self.first = first

    def __iter__(self):
        if self.first is not None:
            first, self.first = self.first, None
            return first
        return iter(self.make())


def replay_to_files(trajectory, poses: str | None = "-", events: str | None = None, scene: str | None = None,
                    terrain: str | None = None, vehicle: str = "t72", matcher: str = "auto",
                    discrete: bool = False, escalate: bool | None = None, tolerance: float | None = None,
                    world=None, up: str | None = None, cache: bool = False,
                    progress: Callable[[int], None] | None = None, observe: Callable | None = None,
                    attitude_tolerance: float | None = None, fmt: str | None = None, gates: bool = True):
    """Replay a trajectory streamed to files, as ``tankcd replay`` does: the poses CSV (``-``
    standard output, None: none) and the events JSON Lines (None: only counted), or Parquet for a
    name ending in ``.parquet`` (typed columns, the CRS, conventions and sources' SHA-256 in the
    file's metadata; pyarrow is the ``parquet`` extra, its absence an InputError before any work);
    written under temporary names and renamed together when complete; memory bounded by the chunk
    whatever the trajectory's length. Returns the closing summary (``replay.records.ReplaySummary``).
    ``progress(rows)`` after every chunk; ``observe(chunk, poses, events)`` sees every chunk.
    ``fmt``: the inputs' format (csv, gpx, pcap, pcapng) where neither name nor content says
    (docs/formats.md, "Trajectory inputs: formats")."""
    from tankcd_cli.replay.outputs import check_writable
    from tankcd_cli.replay.records import ReplayOutputs
    from tankcd_cli.replay.run import run_replay

    check_writable(poses, events)  # before the world is loaded
    trajectory = _with_format(trajectory, fmt)
    w = _world(world, scene, terrain, vehicle, up, cache, None)
    sources = [str(p) for p in trajectory] if isinstance(trajectory, (list, tuple)) else None
    return run_replay(w, _chunks(trajectory, w), ReplayOutputs(poses, events),
                      _options(matcher, escalate, tolerance, discrete, attitude_tolerance, gates), progress=progress,
                      observe=observe,
                      sources=sources)


def export_trajectory(trajectory: str, output: str, scene: str | None = None, terrain: str | None = None,
                      crs: str | None = None, fmt: str | None = None, up: str | None = None) -> dict:
    """Write any trajectory input (a trajectory CSV, a geographic CSV, GPX, a DIS capture) as the
    trajectory CSV tankcd reads (``t,entity,x,y,yaw_deg``, and ``turret_deg,gun_deg`` where the
    input has them: the layout of docs/formats.md, "Trajectory CSV written by tankcd"), converted
    to a CRS: the terrain's (a store, any terrain input, or a scene's terrain) or ``crs`` (EPSG
    code or WKT; ``EPSG:4326``: ``lon,lat,heading_deg``, the geographic CSV). Geographic inputs
    need one of them (an InputError naming them, before anything is written); a CSV in metres
    needs none. An absolute clock is kept in a ``# time_origin:`` line. ``output``: a file (written beside and
    renamed when complete) or ``-``. ``fmt``: the input's format when its suffix does not say
    (csv, gpx, pcap, pcapng). Returns {"rows", "entities", "skipped"} (packets or lines skipped,
    by reason)."""
    from tankcd_cli.io.trajectory import export_trajectory as _export

    given = [v is not None for v in (scene, terrain, crs)]
    if sum(given) > 1:
        raise ValueError("give at most one of scene=, terrain= and crs=")
    if scene is not None or terrain is not None:
        crs = load_world(scene=scene, terrain=terrain, up=up).crs
    return _export(trajectory, output, crs=crs, fmt=fmt)


def replay_windows(trajectory: str, poses: str | None = "-", events: str | None = None, scene: str | None = None,
                   terrain: str | None = None, vehicle: str = "t72", matcher: str = "auto", discrete: bool = False,
                   escalate: bool | None = None, tolerance: float | None = None, window_seconds: float = 60.0,
                   scheduler: str | None = None, world=None, up: str | None = None,
                   progress: Callable[[int], None] | None = None, attitude_tolerance: float | None = None,
                   jobs: int = 1, gates: bool = True):
    """Replay an exercise (one trajectory file, usually with an ``entity`` column) by time windows of
    ``window_seconds``, each a task: one after the other here, in ``jobs`` forked processes, or on
    the Dask cluster at ``scheduler`` (each worker loads the scene or terrain from its path; a
    window whose worker is lost runs again). The poses and events written are ``replay_to_files``'s, byte for byte (see
    ``replay.windows``; Parquet for a name ending in ``.parquet``, the same tables and metadata);
    memory follows the window. Returns the closing summary
    (``replay.records.ReplaySummary``). ``progress(rows)`` as windows are written."""
    import os

    from tankcd_cli.errors import InputError
    from tankcd_cli.replay.records import ReplayOutputs
    from tankcd_cli.replay.executor import Executor, TaskWorld
    from tankcd_cli.replay.windows import SparseTime, plan_windows, run_windows, window_runner

    if not isinstance(trajectory, str) or trajectory == "-":
        raise InputError(str(trajectory), "a replay by time windows reads a trajectory file (each window reads "
                                          "its own rows), not standard input or arrays")
    if not (np.isfinite(window_seconds) and window_seconds > 0):
        raise ValueError(f"window_seconds must be a positive finite number, not {window_seconds!r}")
    from tankcd_cli.replay.outputs import check_writable

    check_writable(poses, events)  # Parquet without pyarrow: before any work
    options = _options(matcher, escalate, tolerance, discrete, attitude_tolerance, gates)
    if scheduler:
        from tankcd_cli.replay.world import WorldSpec

        import dataclasses

        spec = world.spec if world is not None and world.spec is not None else WorldSpec(
            scene=scene, terrain=terrain, vehicle=vehicle, up=up)
        # workers elsewhere may run in another directory
        spec = dataclasses.replace(spec, **{k: os.path.abspath(getattr(spec, k)) for k in ("scene", "terrain", "store")
                                            if getattr(spec, k)})
        runner = window_runner(TaskWorld(spec, options), Executor(scheduler=scheduler))
        path = os.path.abspath(trajectory)  # workers elsewhere may run in another directory
    else:
        loaded = _world(world, scene, terrain, vehicle, up, False, None)
        runner = window_runner(TaskWorld(loaded.spec, options), Executor(jobs=jobs or 1), loaded=loaded)
        path = trajectory
    # here, an input that is no CSV (a capture, GPX) is decoded and converted once for all the windows
    try:
        plan = plan_windows(path, options, window_seconds, crs=None if scheduler else loaded.crs)
    except SparseTime as sparse:
        from tankcd_cli.errors import collected_warnings, warn

        with collected_warnings() as said:
            warn(trajectory, f"{sparse}: replayed in one piece, which skips empty time (the same poses and events)")
        loaded = _world(world, scene, terrain, vehicle, up, False, None) if scheduler else loaded
        summary = replay_to_files(trajectory, poses, events, world=loaded, matcher=matcher, discrete=discrete,
                                  escalate=escalate, tolerance=tolerance, attitude_tolerance=attitude_tolerance,
                                  progress=progress)
        summary.warnings = list(said) + summary.warnings
        return summary
    return run_windows(path, ReplayOutputs(poses, events), runner, plan, options, progress=progress)


def replay_fleet(trajectories: list, out_dir: str, scene: str | None = None, terrain: str | None = None,
                 vehicle: str = "t72", up: str | None = None, matcher: str = "auto", discrete: bool = False,
                 escalate: bool | None = None, tolerance: float | None = None, jobs: int | None = None,
                 scheduler: str | None = None, split_lines: int | None = 1_000_000,
                 progress: Callable[[str], None] | None = None, on_result: Callable | None = None,
                 out_format: str = "csv", attitude_tolerance: float | None = None, gates: bool = True):
    """Replay many trajectories (paths, globs, ``@lists``) as ``tankcd replay ... --out-dir`` does: each
    into ``out_dir/NAME.poses.csv`` and ``NAME.events.jsonl`` (``out_format="parquet"``:
    ``NAME.poses.parquet`` and ``NAME.events.parquet``), in ``jobs`` processes (default: the
    cores) or on the Dask cluster at ``scheduler``, long ones in parts of ``split_lines`` lines;
    writes ``out_dir/fleet.json`` and returns its ``replay.fleet.FleetSummary``. A failing
    trajectory does not stop the others (its result says why)."""
    import os

    from tankcd_cli.replay.outputs import check_writable
    from tankcd_cli.replay.executor import TaskWorld
    from tankcd_cli.replay.fleet import expand_trajectories, plan_tasks, run_fleet, write_summary
    from tankcd_cli.replay.world import WorldSpec, classify_once

    paths = expand_trajectories(list(trajectories))
    tasks = plan_tasks(paths, out_dir, split_lines, out_format)
    check_writable(tasks[0].whole_poses or tasks[0].poses)  # Parquet without pyarrow: before any directory or work
    os.makedirs(out_dir, exist_ok=True)
    spec = WorldSpec(scene=os.path.abspath(scene) if scene else None,
                     terrain=os.path.abspath(terrain) if terrain else None, vehicle=vehicle, up=up)
    jobs = jobs or os.cpu_count() or 1
    if (scheduler or jobs > 1) and len(tasks) > 1:  # classify once, not once per worker
        spec = classify_once(spec, out_dir, progress)
    options = _options(matcher, escalate, tolerance, discrete, attitude_tolerance, gates)
    fleet = run_fleet(TaskWorld(spec, options), tasks, jobs, scheduler, progress=progress, on_result=on_result)
    write_summary(os.path.join(out_dir, "fleet.json"), fleet)
    return fleet


REPLAY_MODES = ("one", "together", "windows", "fleet")


def replay_mode(trajectories, out_dir: str | None = None, window_seconds: float | None = None,
                together: bool = False, jobs: int | None = None, scheduler: str | None = None) -> str:
    """Which replay ``run_replay`` runs for these inputs and options (``REPLAY_MODES``):

    - ``together``: several files as one exercise (``together``), into one poses and one events output;
    - ``windows``: one exercise by time windows (``window_seconds``), here, in ``jobs`` processes or
      on the cluster at ``scheduler``;
    - ``fleet``: each trajectory into ``out_dir`` (given, or named by several trajectories, a glob
      or an ``@list``, or ``jobs`` or ``scheduler`` without windows);
    - ``one``: one trajectory in one piece.
    """
    from tankcd_cli.replay.fleet import names_a_fleet

    items = [trajectories] if isinstance(trajectories, str) else list(trajectories)
    if together:
        return "together"
    if window_seconds is not None and out_dir is None and not names_a_fleet(items):
        return "windows"
    if out_dir is not None or names_a_fleet(items) or (window_seconds is None and (jobs is not None or scheduler)):
        return "fleet"
    return "one"


def run_replay(trajectories, poses: str | None = "-", events: str | None = None, out_dir: str | None = None,
               window_seconds: float | None = None, together: bool = False, jobs: int | None = None,
               scheduler: str | None = None, world=None, scene: str | None = None, terrain: str | None = None,
               vehicle: str = "t72", up: str | None = None, cache: bool = False, matcher: str = "auto",
               discrete: bool = False, escalate: bool | None = None, tolerance: float | None = None,
               attitude_tolerance: float | None = None, fmt: str | None = None, split_lines: int | None = 1_000_000,
               out_format: str = "csv", progress: Callable[[int], None] | None = None,
               say: Callable[[str], None] | None = None, on_result: Callable | None = None,
               observe: Callable | None = None, gates: bool = True):
    """Run any replay, the one ``replay_mode`` names for these inputs and options: one trajectory
    (or several ``together``) into ``poses`` and ``events`` (``replay_to_files``), one exercise by
    time windows (``replay_windows``), or a fleet into ``out_dir`` (``replay_fleet``; ``say``
    its progress lines, ``on_result`` each task's result). Returns the ``ReplaySummary``, or the
    fleet's ``FleetSummary``. ``trajectories``: a path, or a list of paths, globs and ``@lists``;
    ``progress(rows)`` and ``observe`` as ``replay_to_files`` takes them."""
    mode = replay_mode(trajectories, out_dir, window_seconds, together, jobs, scheduler)
    items = [trajectories] if isinstance(trajectories, str) else list(trajectories)
    how = dict(matcher=matcher, discrete=discrete, escalate=escalate, tolerance=tolerance,
               attitude_tolerance=attitude_tolerance, gates=gates)
    if mode == "fleet":
        if out_dir is None:
            raise ValueError("a fleet needs out_dir (one poses and one events file per trajectory)")
        return replay_fleet(items, out_dir, scene=scene, terrain=terrain, vehicle=vehicle, up=up, jobs=jobs,
                            scheduler=scheduler, split_lines=split_lines, progress=say, on_result=on_result,
                            out_format=out_format, **how)
    if mode == "windows":
        return replay_windows(_with_format(items[0], fmt), poses, events, scene=scene, terrain=terrain,
                              vehicle=vehicle, up=up, world=world, window_seconds=window_seconds,
                              scheduler=scheduler, jobs=jobs or 1, progress=progress, **how)
    if mode == "together":
        from tankcd_cli.replay.fleet import expand_trajectories

        trajectory = expand_trajectories(items)
    else:
        trajectory = items[0]
    return replay_to_files(trajectory, poses, events, scene=scene, terrain=terrain, vehicle=vehicle, world=world,
                           up=up, cache=cache, progress=progress, observe=observe, fmt=fmt, **how)


def trajectory_chunks(columns: dict, chunk_rows: int = 65536, crs: str | None = None):
    """A dict of arrays (``t``, ``x``, ``y``, ``yaw_deg``; optional ``turret_deg``, ``gun_deg``, and
    ``entity``: each row's vehicle, which makes the rows an exercise) as the chunks a replay
    streams, checked as a CSV's rows are: every value finite, ``t`` never decreasing (within each
    entity), entity names usable as CSV cells (an InputError names the first bad row, from 0).

    Geographic rows: ``lon``, ``lat`` (deg, WGS 84) in place of ``x``, ``y``, with ``heading_deg``
    (a compass bearing, clockwise from true north) or ``yaw_deg`` (counter-clockwise from true
    east) or neither (each row heads toward its entity's next row, as a GPX track's points do; a
    warning says so), converted to ``crs`` (the terrain's: ``api.replay`` gives it; an InputError
    without one) as the geographic CSV is. ``t`` as ``numpy.datetime64`` values is an absolute
    clock: t counts from the first row and the chunks carry its ``time_origin``."""
    from tankcd_cli.errors import InputError
    from tankcd_cli.io.trajectory import TrajectoryChunk

    columns, origin = _absolute_t(columns)
    if "lon" in columns and "lat" in columns and not ("x" in columns and "y" in columns):
        columns = _geographic_columns(columns, crs)

    missing = [c for c in TRAJECTORY_COLUMNS[:4] if c not in columns]
    if missing:
        raise InputError("trajectory", f"needs the columns {', '.join(TRAJECTORY_COLUMNS[:4])} (missing: "
                                       f"{', '.join(missing)})")
    n = len(np.atleast_1d(columns["t"]))
    has_turret = any(c in columns for c in ("turret_deg", "gun_deg"))
    cols = {}
    for name in TRAJECTORY_COLUMNS:
        if name in columns:
            values = np.atleast_1d(np.asarray(columns[name], dtype=float))
            if values.shape != (n,):
                raise InputError("trajectory", f"column {name} has {values.size} values, t has {n}")
        else:
            values = np.zeros(n)
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            raise InputError("trajectory", f"{name} is not a finite number ({values[bad[0]]!r})",
                             where=f"row {int(bad[0])}")
        if name == "gun_deg":
            from tankcd_cli.io.trajectory import GUN_LIMIT_DEG

            bad = np.flatnonzero(np.abs(values) > GUN_LIMIT_DEG)
            if len(bad):
                raise InputError("trajectory", f"{values[bad[0]]!r} is no gun elevation (-{GUN_LIMIT_DEG:g} to "
                                               f"{GUN_LIMIT_DEG:g} degrees)", where=f"row {int(bad[0])} gun_deg")
        cols[name] = values
    if "entity" in columns:
        names, codes = _entity_codes(columns["entity"], n)
    else:
        names, codes = (), np.zeros(n, dtype=np.int64)
    # t never decreasing within each entity (a stable sort keeps each entity's rows in order)
    order = np.argsort(codes, kind="stable")
    t_sorted, c_sorted = cols["t"][order], codes[order]
    back = np.flatnonzero((np.diff(t_sorted) < 0) & (c_sorted[1:] == c_sorted[:-1]))
    if len(back):
        k, j = int(order[back[0] + 1]), int(order[back[0]])
        who = f"entity {names[codes[k]]!r}: " if names else ""
        raise InputError("trajectory", f"{who}time goes back ({cols['t'][k]!r} after {cols['t'][j]!r} at row {j}); t "
                                       "must be non-decreasing" + (" within each entity" if names else ""),
                         where=f"row {k}")
    piece_start = np.zeros(n, dtype=bool)
    piece_start[order[np.r_[True, c_sorted[1:] != c_sorted[:-1]]] if n else []] = True

    def chunks():
        seen = 0
        for start in range(0, n, chunk_rows):
            sl = slice(start, min(start + chunk_rows, n))
            step = np.arange(sl.start, sl.stop)
            if not names:
                yield TrajectoryChunk(step, sl.start, cols["t"][sl], cols["x"][sl], cols["y"][sl],
                                      cols["yaw_deg"][sl], cols["turret_deg"][sl], cols["gun_deg"][sl], has_turret,
                                      step.copy(), time_origin=origin)
                continue
            seen = max(seen, int(codes[sl].max()) + 1)  # codes in order of first appearance: a prefix
            yield TrajectoryChunk(step, sl.start, cols["t"][sl], cols["x"][sl], cols["y"][sl], cols["yaw_deg"][sl],
                                  cols["turret_deg"][sl], cols["gun_deg"][sl], has_turret, step.copy(),
                                  codes[sl], names[:seen], piece_start[sl], True, time_origin=origin)

    return chunks()


def _absolute_t(columns: dict) -> tuple[dict, float | None]:
    """``t`` as numpy.datetime64 values -> seconds from the first row, and that row's instant as seconds
    since 1970 (the chunks' ``time_origin``); other columns as they are (no origin)."""
    t = columns.get("t")
    if t is None:
        return columns, None
    t = np.atleast_1d(np.asarray(t))
    if t.dtype.kind != "M":
        return columns, None
    from tankcd_cli.errors import InputError
    from tankcd_cli.io.trajectory.csv_rows import epoch_seconds

    ns = t.astype("datetime64[ns]").astype(np.int64)
    bad = np.flatnonzero(np.isnat(t))
    if len(bad):
        raise InputError("trajectory", "t is not a time (NaT)", where=f"row {int(bad[0])}")
    if not len(ns):
        return {**columns, "t": np.zeros(0)}, None
    return {**columns, "t": (ns - ns[0]) / 1e9}, epoch_seconds(*divmod(int(ns[0]), 1_000_000_000))


def _geographic_columns(columns: dict, crs: str | None) -> dict:
    """A dict with ``lon``, ``lat`` (and ``heading_deg``, ``yaw_deg`` or neither) -> the same with ``x``,
    ``y``, ``yaw_deg`` in ``crs``, as the geographic CSV's rows are converted (docs/formats.md)."""
    from tankcd_cli.errors import InputError, warn
    from tankcd_cli.io.gpx import track_headings
    from tankcd_cli.io.trajectory import check_crs, geographic_to_crs

    if "heading_deg" in columns and "yaw_deg" in columns:
        raise InputError("trajectory", "both heading_deg (a compass bearing) and yaw_deg (counter-clockwise from "
                                       "east) beside lon, lat: keep one")
    lon, lat = (np.atleast_1d(np.asarray(columns[c], dtype=float)) for c in ("lon", "lat"))
    if lat.shape != lon.shape:
        raise InputError("trajectory", f"column lat has {lat.size} values, lon has {lon.size}")
    bad = np.flatnonzero(~((np.abs(lon) <= 180.0) & (np.abs(lat) <= 90.0)))
    if len(bad):
        k = int(bad[0])
        raise InputError("trajectory", f"lon {lon[k]!r}, lat {lat[k]!r} is out of range (-180 to 180, -90 to 90 "
                                       "degrees)", where=f"row {k}")
    check_crs(crs, "trajectory")
    compass = "yaw_deg" not in columns
    if "heading_deg" in columns or "yaw_deg" in columns:
        h = np.atleast_1d(np.asarray(columns["heading_deg" if compass else "yaw_deg"], dtype=float))
        if h.shape != lon.shape:
            raise InputError("trajectory", f"the heading has {h.size} values, lon has {lon.size}")
        bad = np.flatnonzero(~np.isfinite(h))
        if len(bad):
            raise InputError("trajectory", f"the heading is not a finite number ({h[bad[0]]!r})",
                             where=f"row {int(bad[0])}")
    else:
        n = len(lon)
        if "entity" in columns:
            _, codes = _entity_codes(columns["entity"], n)
        else:
            codes = np.zeros(n, dtype=np.int64)
        order = np.argsort(codes, kind="stable")
        h = np.full(n, np.nan)
        h[order] = np.degrees(track_headings(lon[order], lat[order], codes[order]))
        if n:
            warn("trajectory", "no heading (heading_deg or yaw_deg) beside lon, lat: each row heads toward its "
                               "vehicle's next row, as a GPX track's points do")
    still = np.isnan(h)  # a vehicle that never moves: yaw 0
    x, y, yaw, bad = geographic_to_crs(lon, lat, np.where(still, 0.0, h), compass, crs, "trajectory")
    yaw[still] = 0.0
    if bad >= 0:
        raise InputError("trajectory", f"lon {lon[bad]!r}, lat {lat[bad]!r} has no place in the terrain's CRS",
                         where=f"row {bad}")
    out = {k: v for k, v in columns.items() if k not in ("lon", "lat", "heading_deg")}
    out.update(x=x, y=y, yaw_deg=yaw)
    return out


def _entity_codes(values, n: int) -> tuple[tuple, np.ndarray]:
    """Entity names (in order of first appearance) and each row's code into them; a name must be an
    entity id once blanks around it are taken off (``io.trajectory.names.entity_id_fault``: not
    empty, no comma, quote or control character such as a line break: it becomes a CSV cell)."""
    from tankcd_cli.errors import InputError
    from tankcd_cli.io.trajectory.names import entity_id_fault

    ids = np.asarray(values, dtype=object).ravel()
    if ids.shape != (n,):
        raise InputError("trajectory", f"column entity has {ids.size} values, t has {n}")
    # the distinct ids first (few), then each checked once: no Python loop over the rows
    raw, first_raw, raw_inverse = np.unique(ids.astype(str), return_index=True, return_inverse=True)
    stripped = np.char.strip(raw)
    wrong = np.flatnonzero([entity_id_fault(str(name)) is not None for name in stripped.tolist()])
    if len(wrong):
        row = int(first_raw[wrong].min())
        raise InputError("trajectory", f"entity {str(ids[row]).strip()!r} is empty or holds a comma, quote or line "
                                       "break", where=f"row {row}")
    text = stripped[raw_inverse.ravel()]
    names, first, inverse = np.unique(text, return_index=True, return_inverse=True)
    rank = np.empty(len(names), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(names))
    return tuple(str(v) for v in names[np.argsort(first, kind="stable")]), rank[inverse.ravel()]


@dataclass
class CollideStats:
    """What ``collide_chunks`` did over a chunk: poses read, poses without a pose (skipped), and
    the node-pair and triangle-pair tests of the tree walks."""

    poses: int = 0
    skipped: int = 0
    node_tests: int = 0
    tri_tests: int = 0


def collide(scene: str, poses, all_contacts: bool = False) -> list:
    """The scene's vehicle at given poses against its obstacles: a list of events (dicts as the
    events JSON Lines' lines), one per pose and obstacle in contact.

    poses : a path to a poses CSV, or a dict of arrays with ``x``, ``y``, ``z`` and either
        ``roll_deg``, ``pitch_deg``, ``yaw_deg`` or ``qw``, ``qx``, ``qy``, ``qz`` (optional ``step``,
        ``t``, ``turret_deg``, ``gun_deg``: the turret and gun turned so): what ``place`` and
        ``replay`` return
    """
    return [e for events, _ in collide_chunks(scene, poses, all_contacts) for e in events]


def collide_chunks(scene: str, poses, all_contacts: bool = False, cache: bool = True,
                   progress: Callable[[str], None] | None = None):
    """``collide`` chunk by chunk, for poses files of any length: yields (events, CollideStats).
    ``cache``: keep the obstacles' trees beside the scene (``.tankcd-cache/``) and reuse them."""
    from tankcd_cli.collision.obstacles import collide_obstacles, load_obstacles, scene_vehicle_body
    from tankcd_cli.geometry.motion import quaternion_matrix
    from tankcd_cli.geometry.pose import rotation_matrix
    from tankcd_cli.scene import load_scene

    sc = load_scene(scene)
    obstacles = load_obstacles(sc, cache=cache, progress=progress)
    body = scene_vehicle_body(sc)
    if isinstance(poses, str):
        from tankcd_cli.io.poses_csv import read_poses

        chunks = read_poses(poses)
    else:
        p = {k: np.atleast_1d(np.asarray(v)) for k, v in poses.items()}
        n = len(p["x"])
        if all(k in p for k in ("qw", "qx", "qy", "qz")):
            R = quaternion_matrix(np.column_stack([p[k].astype(float) for k in ("qw", "qx", "qy", "qz")]))
        else:
            R = rotation_matrix(*(np.radians(p[k].astype(float)) for k in ("roll_deg", "pitch_deg", "yaw_deg")))
        pos = np.column_stack([p[k].astype(float) for k in ("x", "y", "z")])
        valid = np.isfinite(pos).all(axis=1) & np.isfinite(R.reshape(n, 9)).all(axis=1)
        chunks = [(p.get("step", np.arange(n)), p.get("t", np.full(n, np.nan)), R, pos, valid,
                   np.radians(p.get("turret_deg", np.zeros(n)).astype(float)),
                   np.radians(p.get("gun_deg", np.zeros(n)).astype(float)))]
    for step, t, R, pos, valid, turret, gun in chunks:
        idx = np.flatnonzero(valid)
        hits = collide_obstacles(body, obstacles, R[idx], pos[idx], turret[idx], gun[idx], all_contacts=all_contacts)
        events = []
        for k, o, part, point, n_contacts in zip(hits.pose, hits.obstacle, hits.part, hits.point, hits.contacts):
            i = idx[k]
            ti = float(t[i])
            events.append({"step": int(step[i]), "t": None if not np.isfinite(ti) else round(ti, 6),
                           "kind": "obstacle", "a": body.part_names[part], "b": obstacles[o].name,
                           "point": [round(float(c), 4) for c in point], "contacts": int(n_contacts)})
        yield events, CollideStats(len(valid), int((~valid).sum()), hits.node_tests, hits.tri_tests)


def gun_envelope(vehicle="t72", azimuth_deg=None, method: str = "exact", resolution_deg: float = 0.01) -> dict:
    """The lowest safe gun elevation at each turret azimuth (deg; default every degree): a dict of
    arrays ``azimuth``, ``min_elevation`` (NaN where even full elevation touches a drum),
    ``limited`` (a drum sets the limit), ``blocked_by`` (drum index, -1), ``checked`` (every
    elevation above the limit was tested clear on a 0.25 deg grid). ``vehicle``: a preset name, a
    ``Vehicle``, or a scene path (its ``[vehicle]``)."""
    from tankcd_cli.collision.internal import elevation_envelope

    if isinstance(vehicle, str) and vehicle.lower().endswith(".toml"):
        from tankcd_cli.scene import load_scene

        v = load_scene(vehicle).vehicle
    else:
        v = _as_vehicle(vehicle)
    az = np.arange(0.0, 360.0, 1.0) if azimuth_deg is None else np.atleast_1d(np.asarray(azimuth_deg, dtype=float))
    return elevation_envelope(v, az, resolution_deg=resolution_deg, method=method)


def describe(path: str, scene: str | None = None) -> dict:
    """What ``tankcd info PATH --json`` prints, as a dict of plain values: the facts of any file
    tankcd reads or writes (a store, a tree, a scene, a trajectory, a raw terrain, never classified,
    events, poses, Parquet, a replay summary, fleet.json; docs/formats.md, "info --json").
    ``scene``: with a trajectory, which vehicle of that scene each entity is. A file that is none of
    them is an InputError."""
    from tankcd_cli.describe import describe_store

    return describe_store(str(path), scene)


REPORT_SUFFIXES = (".html", ".geojson", ".czml", ".pcap")
"""What ``report`` writes, by the output's suffix (any case): the review page, GeoJSON, CZML, a DIS
capture with Collision PDUs."""


def check_report(poses: str, events: str, output: str, capture: str | None = None,
                 inputs: dict | None = None) -> str:
    """The output's kind (one of ``REPORT_SUFFIXES``) after the checks ``report`` makes before any
    work, each an InputError naming the file: a known suffix, ``capture`` exactly for ``.pcap``, no
    output onto an input (``poses``, ``events``, ``capture``, and ``inputs``: label -> path), the
    output's folder there. Nothing is read but the file system's names."""
    import os

    from tankcd_cli.errors import InputError
    from tankcd_cli.io.atomic import check_folders
    from tankcd_cli.io.files import same_path

    if output in (None, "", "-"):
        raise InputError(str(output or "-"), "a review is written to a file (a name ending in "
                         f"{', '.join(REPORT_SUFFIXES)}), not standard output")
    kind = os.path.splitext(str(output))[1].lower()
    if kind not in REPORT_SUFFIXES:
        raise InputError(output, f"unknown output suffix {os.path.splitext(str(output))[1] or '(none)'!r}: "
                                 f"give a name ending in {', '.join(REPORT_SUFFIXES)}")
    if kind == ".pcap" and not capture:
        raise InputError(output, "a .pcap review needs --capture, the DIS capture that was replayed (its packets "
                                 "are copied with the Collision PDUs among them)")
    if kind != ".pcap" and capture:
        raise InputError(capture, f"--capture goes with a .pcap output only (the output is {kind})")
    named = {"POSES": poses, "EVENTS": events, "--capture": capture, **(inputs or {})}
    for label, path in named.items():
        if path not in (None, "-") and same_path(str(output), str(path)):
            raise InputError(output, f"the output is also {label} {path}: no output overwrites an input")
    check_folders(output)
    return kind


def require_report_crs(kind: str, world, where: str | None = None) -> None:
    """GeoJSON and CZML are in longitude and latitude: an InputError when ``world``'s terrain has no
    CRS (``kind``: ``check_report``'s)."""
    from tankcd_cli.errors import InputError

    if kind in (".geojson", ".czml") and not world.crs:
        raise InputError(where or "the terrain", f"the terrain has no CRS: {kind[1:].upper()} needs longitude and "
                                                 "latitude (give the terrain a CRS, or write .html)")


def report(poses: str, events: str, output: str, scene: str | None = None, terrain: str | None = None,
           capture: str | None = None, world=None, vehicle: str = "t72", up: str | None = None,
           progress: Callable[[str], None] | None = None) -> dict:
    """Write what reviewers open of a replay's ``poses`` (CSV or Parquet) and ``events`` (JSON
    Lines or Parquet), chosen by ``output``'s suffix (docs/formats.md, "Outputs for review"):
    ``.html`` the review page over the terrain's class map, ``.geojson`` RFC 7946, ``.czml`` for
    Cesium, ``.pcap`` the DIS ``capture`` that was replayed with a Collision PDU per contact.

    The world (``scene=`` or ``terrain=`` with ``vehicle``, ``up``, or a loaded ``world=``) gives
    the CRS and the vehicles' footprints. Every refusal is an InputError before anything is
    written: an unknown suffix, ``capture`` missing for ``.pcap`` or given for another output, an
    output onto an input, GeoJSON or CZML over a terrain without a CRS, and the checks of the poses
    against the events (``report.inputs.read_review``). Returns {"output", "vehicles", "events",
    "bytes"}, and for a capture "pdus": the Collision PDUs added."""
    import os

    from tankcd_cli.errors import InputError
    from tankcd_cli.report.inputs import read_review
    from tankcd_cli.report.review import Source

    say = progress or (lambda text: None)
    inputs = {"--scene": scene, "--terrain": terrain}
    if world is None and (scene is None) == (terrain is None):
        raise ValueError("give scene= or terrain= (one of them), or world=")
    if (scene is None) != (terrain is None):
        from tankcd_cli.replay.world import WorldSpec, world_inputs

        inputs.update(world_inputs(WorldSpec(scene=scene, terrain=terrain, vehicle=vehicle, up=up)))
    kind = check_report(poses, events, output, capture, inputs)
    if kind == ".pcap" and not os.path.isfile(capture):
        raise InputError(capture, "no such file" if not os.path.exists(capture) else "is not a file")
    say("loading the world")
    w = _world(world, scene, terrain, vehicle, up, False, say)
    require_report_crs(kind, w, scene or terrain)
    crs = w.crs
    from tankcd_cli.io.parquet import sha256_of

    # the scene and the capture hashed (a terrain, maybe gigabytes, named only: the Parquet metadata
    # carries the replay's own record of it)
    sources = [Source("scene", str(scene), sha256_of(scene))] if scene else []
    sources += [Source("terrain", str(terrain))] if terrain else []
    if capture:
        sources.append(Source("capture", str(capture), sha256_of(capture)))
    say("reading the poses and events")
    review = read_review(poses, events, crs_wkt=crs, sources=sources, vehicle_length=w.vehicle.hull_length,
                         vehicle_width=w.vehicle.hull_width)
    say(f"writing {output}")
    if kind == ".html":
        from tankcd_cli.report.background import terrain_background
        from tankcd_cli.report.page import write_page

        write_page(review, terrain_background(w), output)
    elif kind == ".geojson":
        from tankcd_cli.report.geojson import write_geojson

        write_geojson(review, output)
    elif kind == ".czml":
        from tankcd_cli.report.czml import write_czml

        write_czml(review, output)
    pdus = None
    if kind == ".pcap":
        from tankcd_cli.report.collision_pdus import write_collision_pdus

        pdus = write_collision_pdus(review, capture, output, lambda e: w.kinds[w.kind_of(e)].vehicle)
    return {"output": str(output), "vehicles": len(review.tracks), "events": len(review.events),
            "bytes": os.path.getsize(output) if os.path.isfile(output) else 0,
            **({"pdus": int(pdus)} if pdus is not None else {})}
