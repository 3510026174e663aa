"""tankcd_cli.api: the library face gives what the command line gives, for arrays and files alike."""

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tankcd_cli import api
from tankcd_cli.errors import InputError

SAMPLE = Path(__file__).resolve().parent.parent / "sample_data"


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    out = tmp_path_factory.mktemp("api") / "battlefield.h5"
    done = api.classify(str(SAMPLE / "battlefield.asc"), str(out))
    assert done.layout == "grid" and Path(done.output) == out
    return str(out)


def _patrol(rows=200):
    with open(SAMPLE / "patrol.csv") as fh:
        data = list(csv.DictReader(fh))[:rows]
    return {k: np.array([float(r[k]) for r in data]) for k in data[0]}


def test_importing_the_api_stays_lean():
    code = "import sys, tankcd_cli.api; print(sorted(m for m in ('scipy', 'matplotlib', 'trimesh', 'rasterio', " \
           "'h5py') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_place_gives_the_poses_csv_columns_as_arrays(store):
    from tankcd_cli.io.poses_csv import COLUMNS

    terrain = api.open_terrain(store)
    poses = api.place(terrain, [500050.0, 500060.0, 1e9], [4500050.0, 4500060.0, 0.0], [0.0, 45.0, 0.0])
    assert list(poses) == list(COLUMNS)
    assert poses["status"].tolist() == ["ok", "ok", "off"] and poses["matcher"][2] == "none"
    assert np.isnan(poses["z"][2]) and np.isfinite(poses["z"][:2]).all()
    q = np.column_stack([poses[k][:2] for k in ("qw", "qx", "qy", "qz")])
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0)
    # a scalar is one row; a path is opened on the way; every matcher by name
    one = api.place(store, 500050.0, 4500050.0, 0.0, matcher="reference")
    assert one["matcher"].tolist() == ["reference"] and one["penetration"][0] < 1e-6
    with pytest.raises(ValueError, match="unknown matcher"):
        api.place(terrain, 0, 0, 0, matcher="three_point")


def test_replay_of_arrays_is_the_replay_of_the_file_and_of_the_command(store, tmp_path, run):
    columns = _patrol()
    path = tmp_path / "patrol.csv"
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg,turret_deg,gun_deg\n")
        for k in range(len(columns["t"])):
            fh.write(",".join(repr(float(columns[c][k])) for c in ("t", "x", "y", "yaw_deg", "turret_deg", "gun_deg"))
                     + "\n")
    scene = str(SAMPLE / "scene.toml")
    world = api.load_world(scene=scene)
    from_arrays = api.replay(columns, world=world)
    from_file = api.replay(str(path), world=world)
    for k in from_arrays[0]:
        np.testing.assert_array_equal(from_arrays[0][k], from_file[0][k])
    assert from_arrays[1] == from_file[1]
    # the command line's bytes are the API's values, printed
    result = run("replay", path, "--scene", scene, "--events", "e.jsonl")
    assert result.exit_code == 0, result.stderr
    printed = list(csv.DictReader(io.StringIO(result.stdout)))
    assert len(printed) == len(columns["t"])
    np.testing.assert_allclose([float(r["z"]) for r in printed], from_file[0]["z"], atol=6e-5)
    assert [r["matcher"] for r in printed] == from_file[0]["matcher"].tolist()
    lines = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    assert lines == from_file[1]


def test_an_exercise_of_arrays_is_the_exercise_of_the_file(tmp_path):
    """An ``entity`` array makes the arrays an exercise, as the column makes a CSV one: the same poses
    (with the entity of each row) and events, contacts between the vehicles included."""
    columns = _patrol(120)
    k = len(columns["t"])
    # a second tank parked across the patrol's path a third of the way along, for its whole time
    parked = {c: np.full(2, columns[c][k // 3]) for c in columns}
    parked["t"] = np.array([columns["t"][0], columns["t"][-1]])
    both = {c: np.r_[columns[c], parked[c]] for c in columns}
    order = np.argsort(both["t"], kind="stable")
    both = {c: v[order] for c, v in both.items()}
    both["entity"] = np.r_[["patrol"] * k, ["parked"] * 2][order]
    path = tmp_path / "exercise.csv"
    with open(path, "w") as fh:
        fh.write("t,entity,x,y,yaw_deg,turret_deg,gun_deg\n")
        for i in range(len(order)):
            fh.write(",".join([repr(float(both["t"][i])), both["entity"][i]]
                              + [repr(float(both[c][i])) for c in ("x", "y", "yaw_deg", "turret_deg", "gun_deg")])
                     + "\n")
    world = api.load_world(scene=str(SAMPLE / "scene.toml"))
    from_arrays = api.replay(both, world=world)
    from_file = api.replay(str(path), world=world)
    assert from_arrays[0].keys() == from_file[0].keys() and "entity" in from_arrays[0]
    for c in from_arrays[0]:
        np.testing.assert_array_equal(from_arrays[0][c], from_file[0][c])
    assert from_arrays[1] == from_file[1]
    assert any(e["kind"] == "vehicle" for e in from_arrays[1])
    with pytest.raises(InputError, match="row 3: entity 'b': time goes back"):
        list(api.trajectory_chunks({"t": [0.0, 5.0, 1.0, 0.5], "x": [0.0] * 4, "y": [0.0] * 4,
                                    "yaw_deg": [0.0] * 4, "entity": ["a", "b", "a", "b"]}))
    with pytest.raises(InputError, match="row 1: entity 'x,y' is empty or holds a comma"):
        list(api.trajectory_chunks({"t": [0.0, 1.0], "x": [0.0] * 2, "y": [0.0] * 2, "yaw_deg": [0.0] * 2,
                                    "entity": ["a", "x,y"]}))


def test_the_certificates_tolerances_reach_the_replay(store, tmp_path, run):
    """A tighter attitude tolerance escalates more poses, and never fewer, in the API and on the
    command line alike; the looser default escalates a subset of the tighter's poses."""
    columns = _patrol(600)
    world = api.load_world(terrain=store)
    default = api.replay(columns, world=world, discrete=True)[0]
    tight = api.replay(columns, world=world, discrete=True, attitude_tolerance=0.1)[0]
    up_default = np.char.endswith(default["matcher"].astype(str), "+reference")
    up_tight = np.char.endswith(tight["matcher"].astype(str), "+reference")
    assert up_tight.sum() > up_default.sum() and not (up_default & ~up_tight).any()
    with pytest.raises(ValueError, match="attitude_tolerance must be positive"):
        api.replay(columns, world=world, attitude_tolerance=0.0)
    with pytest.raises(ValueError, match="tolerance must be positive"):
        api.place(store, 500050.0, 4500050.0, 0.0, tolerance=float("nan"))
    path = tmp_path / "patrol.csv"
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        for k in range(len(columns["t"])):
            fh.write(",".join(repr(float(columns[c][k])) for c in ("t", "x", "y", "yaw_deg")) + "\n")
    result = run("replay", path, "--terrain", store, "--discrete", "--attitude-tolerance", "0.1")
    assert result.exit_code == 0, result.stderr
    printed = [r["matcher"] for r in csv.DictReader(io.StringIO(result.stdout))]
    assert printed == tight["matcher"].tolist()


def test_replay_to_files_streams_and_summarizes(store, tmp_path):
    summary = api.replay_to_files(str(SAMPLE / "patrol.csv"), poses=str(tmp_path / "p.csv"),
                                  events=str(tmp_path / "e.jsonl"), terrain=store, discrete=True)
    assert summary.rows == 1144 and summary.mode == "discrete" and summary.between == {}
    assert summary.effects == {"terrain_contact": True, "obstacles": False, "internal": True}  # a T-72: drums
    assert len((tmp_path / "p.csv").read_text().splitlines()) == 1145


def test_bad_trajectories_name_the_row():
    good = {"t": [0.0, 1.0, 2.0], "x": [0.0, 1.0, 2.0], "y": [0.0, 0.0, 0.0], "yaw_deg": [0.0, 0.0, 0.0]}
    with pytest.raises(InputError, match="row 2: time goes back"):
        list(api.trajectory_chunks({**good, "t": [0.0, 1.0, 0.5]}))
    with pytest.raises(InputError, match="row 1: y is not a finite number"):
        list(api.trajectory_chunks({**good, "y": [0.0, np.nan, 0.0]}))
    with pytest.raises(InputError, match="missing: yaw_deg"):
        list(api.trajectory_chunks({k: v for k, v in good.items() if k != "yaw_deg"}))
    with pytest.raises(InputError, match="column x has 2 values, t has 3"):
        list(api.trajectory_chunks({**good, "x": [0.0, 1.0]}))
    chunks = list(api.trajectory_chunks(good, chunk_rows=2))
    assert [c.step.tolist() for c in chunks] == [[0, 1], [2]] and not chunks[0].has_turret
    with pytest.raises(ValueError, match="scene= or terrain="):
        api.replay(good)


def test_collide_on_arrays_gives_the_events_of_collide_on_the_file(tmp_path, run):
    scene = str(SAMPLE / "scene.toml")
    columns = {k: v for k, v in _patrol(260).items() if k not in ("turret_deg", "gun_deg")}
    poses, _ = api.replay(columns, scene=scene, discrete=True)
    direct = api.collide(scene, poses)
    assert direct and {e["b"] for e in direct} == {"wall"}
    with open(tmp_path / "p.csv", "w") as fh:
        fh.write("step,t,x,y,z,qw,qx,qy,qz\n")
        for k in range(len(poses["x"])):
            fh.write(",".join(repr(float(poses[c][k])) for c in ("step", "t", "x", "y", "z", "qw", "qx", "qy", "qz"))
                     + "\n")
    assert api.collide(scene, str(tmp_path / "p.csv")) == direct
    result = run("collide", "--scene", scene, "--poses", "p.csv")
    assert [json.loads(line) for line in result.stdout.splitlines()] == direct


def test_the_gun_envelope_is_the_collision_layers(tmp_path):
    from tankcd_cli.collision.internal import elevation_envelope
    from tankcd_cli.vehicle import vehicle_preset

    env = api.gun_envelope("t72", [0.0, 170.0, 180.0])
    want = elevation_envelope(vehicle_preset("t72"), np.array([0.0, 170.0, 180.0]))
    np.testing.assert_array_equal(env["min_elevation"], want["min_elevation"])
    assert env["min_elevation"][0] == -6.0 and env["min_elevation"][2] > -6.0
    no_drums = api.gun_envelope(api.vehicle("t72", fuel_drums=False))
    assert (no_drums["min_elevation"] == -6.0).all() and len(no_drums["azimuth"]) == 360
    (tmp_path / "s.toml").write_text('[vehicle]\npreset = "m1"\n')
    assert (api.gun_envelope(str(tmp_path / "s.toml"))["min_elevation"] == -10.0).all()
    with pytest.raises(InputError, match="unknown vehicle preset"):
        api.vehicle("tiger")


def test_arrays_in_lon_lat_are_converted_as_the_geographic_csv(tmp_path):
    pyproj = pytest.importorskip("pyproj")
    import warnings

    from tankcd_cli.errors import SetupWarning
    from tankcd_cli.io.trajectory import read_trajectory

    geod = pyproj.Geod(ellps="WGS84")
    lon, lat = [10.0], [50.0]
    for az in (80, 80, 95, 95, 110):
        x, y, _ = geod.fwd(lon[-1], lat[-1], az, 5.0)
        lon.append(x)
        lat.append(y)
    t = np.arange(6.0)
    heading = np.array([80, 80, 95, 95, 110, 110.0])
    wkt = pyproj.CRS("EPSG:32632").to_wkt()

    def joined(chunks):
        chunks = list(chunks)
        return {f: np.concatenate([getattr(c, f) for c in chunks]) for f in ("t", "x", "y", "yaw_deg")}

    for given, header, cells in ((dict(heading_deg=heading), "t,lon,lat,heading_deg", heading),
                                 (dict(yaw_deg=90 - heading), "t,lon,lat,yaw_deg", 90 - heading),
                                 ({}, "t,lon,lat", None)):
        path = tmp_path / "g.csv"
        path.write_text(header + "\n" + "".join(
            f"{float(a)!r},{b!r},{c!r}" + ("" if cells is None else f",{float(cells[k])!r}") + "\n"
            for k, (a, b, c) in enumerate(zip(t, lon, lat))))
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", SetupWarning)
            mine = joined(api.trajectory_chunks({"t": t, "lon": lon, "lat": lat, **given}, crs=wkt))
            theirs = joined(read_trajectory(str(path), crs=wkt))
        assert (len(said) == 2) == (cells is None)  # no heading: both warn (the track's is taken)
        for f in mine:
            np.testing.assert_array_equal(mine[f], theirs[f], err_msg=f)
    with pytest.raises(InputError, match="CRS"):
        list(api.trajectory_chunks({"t": t, "lon": lon, "lat": lat, "heading_deg": heading}))
    with pytest.raises(InputError, match="row 2: lon"):
        list(api.trajectory_chunks({"t": t, "lon": [10, 10, 200, 10, 10, 10], "lat": lat, "heading_deg": heading},
                                   crs=wkt))


def test_arrays_with_datetime64_times_carry_their_clock():
    when = np.datetime64("2026-05-04T10:00:00.250") + np.arange(3) * np.timedelta64(500, "ms")
    chunks = list(api.trajectory_chunks({"t": when, "x": [0, 1, 2], "y": [0, 0, 0], "yaw_deg": [0, 0, 0]}))
    from tankcd_cli.io.trajectory import utc_text

    assert chunks[0].t.tolist() == [0.0, 0.5, 1.0] and utc_text(chunks[0].time_origin) == "2026-05-04T10:00:00.25Z"
