"""Absolute clocks through a replay: files replayed together meet on their UTC times, not their first
rows; the summary, info and the Parquet metadata give the origin; a mix of absolute and relative times
is refused. The truths are closed forms of the motions the tests write (two guns meeting head-on)."""

import json

import numpy as np
import pytest

pyproj = pytest.importorskip("pyproj")
rasterio = pytest.importorskip("rasterio")

WEST, NORTH = 500_000.0, 5_540_000.0  # UTM 32N, near 9 E 50 N: the zone's central meridian
Y = NORTH - 30.0
GUN = 6.1  # m from a T-72's origin to its muzzle, level (as test_vehicles' closed form)


@pytest.fixture
def ground(tmp_path):
    """A flat GeoTIFF in EPSG:32632 (160 x 80 m, 1 m posts) and a scene on it (T-72s without drums)."""
    from rasterio.transform import from_origin

    with rasterio.open(tmp_path / "ground.tif", "w", driver="GTiff", height=80, width=160, count=1, dtype="float32",
                       crs="EPSG:32632", transform=from_origin(WEST, NORTH, 1.0, 1.0)) as dst:
        dst.write(np.full((80, 160), 100.0, dtype="float32"), 1)
    (tmp_path / "scene.toml").write_text('[terrain]\npath = "ground.tif"\n\n[vehicle]\npreset = "t72"\n'
                                         'fuel_drums = false\n')
    return tmp_path


def _lonlat(x, y):
    lon, lat = pyproj.Transformer.from_crs("EPSG:32632", "EPSG:4326", always_xy=True).transform(x, y)
    return np.asarray(lon).tolist(), np.asarray(lat).tolist()


def _iso(seconds, zone_hours=0):
    """2026-05-04T10:00:00Z plus ``seconds``, written in the zone UTC+zone_hours."""
    from datetime import datetime, timedelta, timezone

    tz = timezone(timedelta(hours=zone_hours))
    when = datetime(2026, 5, 4, 10, 0, 0, tzinfo=timezone.utc) + timedelta(seconds=seconds)
    text = when.astimezone(tz).isoformat(timespec="microseconds")
    return text.replace("+00:00", "Z")


def _f(v):
    return repr(float(v))


def _gpx_a(path, seconds=np.arange(0.0, 12.01, 0.5)):
    """Tank A in a GPX track: from x = WEST + 10 east at 8 m/s from 10:00:00Z."""
    lon, lat = _lonlat(WEST + 10 + 8 * seconds, np.full(len(seconds), Y))
    pts = "".join(f'<trkpt lat="{la!r}" lon="{lo!r}"><time>{_iso(s)}</time></trkpt>'
                  for lo, la, s in zip(lon, lat, seconds))
    path.write_text('<?xml version="1.0"?><gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">'
                    f"<trk><name>A</name><trkseg>{pts}</trkseg></trk></gpx>\n")  # on one line, as many are


def _csv_b(path, zone_hours=2):
    """Tank B in a CSV, x, y in the terrain's CRS, ISO times in UTC+2: from x = WEST + 150 west at 7 m/s
    from 10:00:05Z (12:00:05+02:00)."""
    seconds = np.arange(5.0, 13.01, 0.5)
    path.write_text("t,x,y,yaw_deg\n" + "".join(f"{_iso(s, zone_hours)},{_f(WEST + 150 - 7 * (s - 5))},{Y!r},180\n"
                                                for s in seconds))


def _events(folder, name="e.jsonl"):
    return [json.loads(line) for line in (folder / name).read_text().splitlines()]


def test_a_gpx_track_and_a_csv_in_another_zone_meet_at_their_utc_times(run, ground):
    _gpx_a(ground / "A.gpx")
    _csv_b(ground / "B.csv")
    result = run("replay", "A.gpx", "B.csv", "--together", "--scene", "scene.toml", "--poses", "p.csv",
                 "--events", "e.jsonl", "--summary", "s.json")
    assert result.exit_code == 0, result.stderr
    vehicle = [e for e in _events(ground) if e["kind"] == "vehicle"]
    # the guns meet when 10 + 8 t + 6.1 = 150 - 7 (t - 5) - 6.1: t from 10:00:00Z, the earlier start
    t = (150 + 35 - 10 - 2 * GUN) / 15
    assert [(e["a"], e["b"], e["a_part"], e["b_part"]) for e in vehicle] == [("A", "B", "gun", "gun")]
    assert vehicle[0]["t"] == pytest.approx(t, abs=1e-3)
    assert vehicle[0]["point"][0] == pytest.approx(WEST + 10 + 8 * t + GUN, abs=2e-3)
    # muzzle face on muzzle face: the point is the mean of the touching features, on the face within the
    # contact point's 1 cm (docs/formats.md, "Contacts between vehicles"), not its exact centre
    assert vehicle[0]["point"][1] == pytest.approx(Y, abs=1e-2)
    lined_up_by_first_rows = (150 - 10 - 2 * GUN) / 15  # what they met at before: 2.3 s early, 18 m off
    assert abs(vehicle[0]["t"] - lined_up_by_first_rows) > 2
    summary = json.loads((ground / "s.json").read_text())
    assert summary["time_origin"] == "2026-05-04T10:00:00Z"
    poses = (ground / "p.csv").read_text().splitlines()
    first_b = next(r.split(",") for r in poses[1:] if r.split(",")[1] == "B")
    assert float(first_b[2]) == 5.0  # B's first row, 5 s after A's


def test_the_same_files_the_other_way_round_and_one_file_alone(run, ground):
    _gpx_a(ground / "A.gpx")
    _csv_b(ground / "B.csv", zone_hours=-5)  # the same instants, written in UTC-5
    result = run("replay", "B.csv", "A.gpx", "--together", "--scene", "scene.toml", "--poses", "p.csv",
                 "--events", "e.jsonl", "--summary", "s.json")
    assert result.exit_code == 0, result.stderr
    vehicle = [e for e in _events(ground) if e["kind"] == "vehicle"]
    assert len(vehicle) == 1 and vehicle[0]["t"] == pytest.approx((185 - 10 - 2 * GUN) / 15, abs=1e-3)
    assert json.loads((ground / "s.json").read_text())["time_origin"] == "2026-05-04T10:00:00Z"
    # alone, a file's t counts from its own first row, and the summary says when that was
    alone = run("replay", "B.csv", "--scene", "scene.toml", "--poses", "q.csv", "--summary", "-")
    assert alone.exit_code == 0, alone.stderr
    assert json.loads(alone.stdout)["time_origin"] == "2026-05-04T10:00:05Z"
    assert (ground / "q.csv").read_text().splitlines()[1].split(",")[1] == "0.000000"  # step, t, ...


def test_absolute_and_relative_times_together_are_refused_naming_both(run, ground):
    _gpx_a(ground / "A.gpx")
    (ground / "C.csv").write_text("t,x,y,yaw_deg\n0,500100,5539950,0\n1,500101,5539950,0\n")
    result = run("replay", "A.gpx", "C.csv", "--together", "--scene", "scene.toml", "--poses", "p.csv")
    assert result.exit_code == 3
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "A.gpx" in lines[0] and "C.csv" in lines[0] and "absolute" in lines[0], lines
    assert not (ground / "p.csv").exists()
    # two relative files are lined up by their own t, as before; the summary has no origin
    (ground / "D.csv").write_text("t,x,y,yaw_deg\n0,500030,5539950,0\n")
    both = run("replay", "C.csv", "D.csv", "--together", "--scene", "scene.toml", "--poses", "p.csv", "--summary",
               "-")
    assert both.exit_code == 0 and json.loads(both.stdout)["time_origin"] is None


def test_a_capture_and_a_gpx_track_together_count_from_the_earlier(tmp_path):
    from tankcd_cli.io.trajectory import merged_trajectories, read_trajectory
    from tests.io.test_dis import T0
    from tests.io.test_trajectory import _exercise_capture

    cap, rows = _exercise_capture(tmp_path)  # its first packet at T0 + 0.05 s
    from datetime import datetime, timezone

    start = datetime.fromtimestamp(T0 - 3, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    (tmp_path / "g.gpx").write_text(
        '<?xml version="1.0"?><gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1"><trk><name>G</name>'
        f'<trkseg><trkpt lat="50.0" lon="10.0"><time>{start}.25Z</time></trkpt>'
        f'<trkpt lat="50.0001" lon="10.0"><time>{start}.75Z</time></trkpt></trkseg></trk></gpx>\n')
    crs = "EPSG:32632"
    merged = list(merged_trajectories([cap, str(tmp_path / "g.gpx")], chunk_rows=7, crs=crs))
    assert {c.time_origin for c in merged} == {T0 - 3 + 0.25}
    t = np.concatenate([c.t for c in merged])
    names = np.concatenate([c.names() for c in merged])
    alone = np.concatenate([c.t for c in read_trajectory(cap, crs=crs)])
    # the capture's rows 2.8 s after its own clock's t (T0 + 0.05 against T0 - 2.75), the track's as they are
    np.testing.assert_allclose(t[names != "G"], alone + 2.8, atol=1e-6)
    np.testing.assert_allclose(t[names == "G"], [0.0, 0.5], atol=1e-9)
    assert np.all(np.diff(t) >= 0)  # merged in time order


def test_the_parquet_metadata_and_info_give_the_origin(run, ground):
    pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    _gpx_a(ground / "A.gpx")
    _csv_b(ground / "B.csv")
    result = run("replay", "B.csv", "A.gpx", "--together", "--scene", "scene.toml", "--poses", "p.parquet",
                 "--events", "e.parquet")
    assert result.exit_code == 0, result.stderr
    for name in ("p.parquet", "e.parquet"):
        meta = pq.read_schema(ground / name).metadata
        assert json.loads(meta[b"tankcd.replay"])["time_origin"] == "2026-05-04T10:00:00Z"
    info = json.loads(run("info", "B.csv", "--json").stdout)
    assert info["time_origin"] == "2026-05-04T10:00:05Z"
    info = json.loads(run("info", "A.gpx", "--json").stdout)
    assert info["time_origin"] == "2026-05-04T10:00:00Z" and info["entities"][0]["first_trkpt"] == 1


def test_gpx_motion_warnings_name_the_track_point(run, ground):
    seconds = np.array([0.0, 1.0, 2.0, 3.0])
    x = WEST + np.array([10.0, 12.0, 90.0, 92.0])  # 78 m in one second from the second point to the third
    lon, lat = _lonlat(x, np.full(4, Y))
    pts = "".join(f'<trkpt lat="{la!r}" lon="{lo!r}"><time>{_iso(s)}</time></trkpt>' for lo, la, s in
                  zip(lon, lat, seconds))
    (ground / "j.gpx").write_text('<?xml version="1.0"?><gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">'
                                  f"<trk><name>J</name><trkseg>{pts}</trkseg></trk></gpx>\n")
    result = run("replay", "j.gpx", "--scene", "scene.toml", "--poses", "p.csv", "--summary", "s.json")
    assert result.exit_code == 0, result.stderr
    said = json.loads((ground / "s.json").read_text())["warnings"]
    fast = [w for w in said if "faster than any vehicle" in w]
    assert len(fast) == 1 and "trkpt 3: 78.0 m/s from trkpt 2" in fast[0] and "line" not in fast[0], said


def test_api_replay_takes_lon_lat_arrays_as_the_geographic_csv(ground):
    from tankcd_cli import api

    seconds = np.arange(0.0, 6.01, 0.5)
    lon, lat = _lonlat(WEST + 10 + 8 * seconds, np.full(len(seconds), Y))
    (ground / "g.csv").write_text("t,lon,lat,heading_deg\n" + "".join(f"{s!r},{a!r},{b!r},90\n" for s, a, b in
                                                                      zip(seconds.tolist(), lon, lat)))
    world = api.load_world(scene=str(ground / "scene.toml"))
    poses, _ = api.replay({"t": seconds, "lon": lon, "lat": lat, "heading_deg": np.full(len(seconds), 90.0)},
                          world=world)
    want, _ = api.replay(str(ground / "g.csv"), world=world)
    for key in ("x", "y", "z", "yaw_deg", "pitch_deg"):
        np.testing.assert_array_equal(poses[key], want[key], err_msg=key)
    np.testing.assert_allclose(poses["x"], WEST + 10 + 8 * seconds, atol=1e-6)



def test_a_windowed_run_gives_the_origin_as_a_run_in_one_piece(ground):
    """--window-seconds keeps the clock: the summary's time_origin and the Parquet metadata's are the
    one-piece run's."""
    import pyarrow.parquet as pq

    from tankcd_cli import api

    path = ground / "iso.csv"
    path.write_text("t,entity,x,y,yaw_deg\n" + "".join(
        f"2026-05-04T12:00:{s:02d}+02:00,{e},{WEST + 20 + s + 60 * k},{Y},0\n" for s in range(6) for k, e in enumerate("AB")))
    scene = str(ground / "scene.toml")
    whole = api.replay_to_files(str(path), poses=str(ground / "p.parquet"), events=None, scene=scene)
    windows = api.replay_windows(str(path), poses=str(ground / "w.parquet"), events=None, scene=scene,
                                 window_seconds=2.0)
    assert whole.time_origin == windows.time_origin == "2026-05-04T10:00:00Z"
    meta = [json.loads(pq.read_schema(ground / f).metadata[b"tankcd.replay"]) for f in ("p.parquet", "w.parquet")]
    assert meta[0]["time_origin"] == meta[1]["time_origin"] == "2026-05-04T10:00:00Z"
