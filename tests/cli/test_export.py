"""tankcd export: any trajectory input as the trajectory CSV replay reads, in a terrain's CRS."""

import csv

import numpy as np
import pytest

pyproj = pytest.importorskip("pyproj")
rasterio = pytest.importorskip("rasterio")


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(line for line in fh if not line.startswith("#")))


@pytest.fixture
def capture(tmp_path):
    """The DIS tests' exercise (three tanks, asynchronous, one late, DIS 6 and 7) as a pcap, and a
    GeoTIFF in UTM 32N under it (rolling ground, 10 m posts)."""
    from rasterio.transform import from_origin

    from tests.io.test_trajectory import _exercise_capture

    path, rows = _exercise_capture(tmp_path)
    x, y = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform([9.98, 10.02],
                                                                                           [49.98, 50.02])
    west, north = np.floor(x[0] / 10) * 10, np.ceil(y[1] / 10) * 10
    cols, nrows = int((x[1] - west) / 10) + 2, int((north - y[0]) / 10) + 2
    gx, gy = np.meshgrid(np.arange(cols) * 10.0, np.arange(nrows) * 10.0)
    z = (150 + 3 * np.sin(gx / 90) * np.cos(gy / 70)).astype("float32")
    tif = tmp_path / "ground.tif"
    with rasterio.open(tif, "w", driver="GTiff", height=nrows, width=cols, count=1, dtype="float32",
                       crs="EPSG:32632", transform=from_origin(west, north, 10.0, 10.0)) as dst:
        dst.write(z, 1)
    return path, rows, str(tif)


def test_a_capture_exported_replays_to_the_captures_poses(run, tmp_path, capture):
    path, rows, tif = capture
    assert run("-q", "classify", tif, "-o", "ground.h5").exit_code == 0
    done = run("export", path, "--terrain", "ground.h5", "-o", "export.csv")
    assert done.exit_code == 0, done.stderr
    assert f"export: {len(rows)} rows of 3 entities to export.csv" in done.stderr
    exported = _rows(tmp_path / "export.csv")
    assert list(exported[0]) == ["t", "entity", "x", "y", "yaw_deg", "turret_deg", "gun_deg"]
    assert [r["entity"] for r in exported] == [e for _, e, _, _ in rows]
    # the positions are pyproj's conversion of the ECEF locations written into the PDUs
    loc = np.array([r[3]["location"] for r in rows])
    x, y, _ = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:32632", always_xy=True).transform(*loc.T)
    np.testing.assert_allclose([float(r["x"]) for r in exported], x, atol=1e-5)
    np.testing.assert_allclose([float(r["y"]) for r in exported], y, atol=1e-5)
    np.testing.assert_allclose([float(r["t"]) for r in exported], [0.05 + t for t, *_ in rows], atol=1e-6)
    # replaying the export is replaying the capture: the same poses, to the poses' printed precision
    for source, out in ((path, "from_capture.csv"), ("export.csv", "from_export.csv")):
        got = run("-q", "replay", source, "--terrain", "ground.h5", "--poses", out)
        assert got.exit_code == 0, got.stderr
    a, b = _rows(tmp_path / "from_capture.csv"), _rows(tmp_path / "from_export.csv")
    assert len(a) == len(b) == len(rows)
    for ra, rb in zip(a, b):
        assert ra.keys() == rb.keys() and ra["entity"] == rb["entity"] and ra["matcher"] == rb["matcher"]
        for key in ("t", "x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg"):
            assert float(ra[key]) == pytest.approx(float(rb[key]), abs=2e-4), key


def test_a_geographic_csv_to_a_crs_given_by_name(run, tmp_path):
    (tmp_path / "gps.csv").write_text("t,lon,lat,heading_deg\n0,10.0,50.0,0\n1,10.0001,50.0,90\n")
    done = run("export", "gps.csv", "--crs", "EPSG:32632", "-o", "-")
    assert done.exit_code == 0, done.stderr
    got = list(csv.DictReader(done.stdout.splitlines()))
    x, y = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform([10.0, 10.0001],
                                                                                           [50.0, 50.0])
    np.testing.assert_allclose([float(r["x"]) for r in got], x, atol=1e-5)
    np.testing.assert_allclose([float(r["y"]) for r in got], y, atol=1e-5)
    # a compass heading of 0 (true north) is about 90 deg of grid yaw, off by the grid's convergence
    convergence = float(got[0]["yaw_deg"]) - 90.0
    assert 0.5 < abs(convergence) < 1.5  # 10 deg E in zone 32 (central meridian 9 deg E), 50 deg N
    assert got[0]["entity"] == "gps"


def test_bad_input_and_usage(run, tmp_path):
    (tmp_path / "gps.csv").write_text("t,lon,lat,heading_deg\n0,10.0,50.0,0\n")
    lost = run("export", "gps.csv", "-o", "out.csv")
    assert lost.exit_code == 3 and len(lost.stderr.strip().splitlines()) == 1 and "gps.csv" in lost.stderr
    assert not (tmp_path / "out.csv").exists()
    both = run("export", "gps.csv", "--crs", "EPSG:32632", "--terrain", "x.h5", "-o", "out.csv")
    assert both.exit_code == 2 and "at most one" in both.stderr
    same = run("export", "gps.csv", "--crs", "EPSG:32632", "-o", "gps.csv")
    assert same.exit_code == 2 and (tmp_path / "gps.csv").read_text().startswith("t,lon,lat")
    assert run("export", "gps.csv", "--crs", "EPSG:32632", "-o", "x.parquet").exit_code == 2


def test_no_crs_for_a_geographic_input_writes_nothing_and_names_the_options(run, tmp_path):
    (tmp_path / "gps.csv").write_text("t,lon,lat,heading_deg\n0,10.0,50.0,0\n")
    for target in ("-", "out.csv"):
        lost = run("export", "gps.csv", "-o", target)
        assert lost.exit_code == 3 and lost.stdout == "", lost.stdout
        lines = lost.stderr.strip().splitlines()
        assert len(lines) == 1 and "gps.csv" in lines[0] and "--terrain, --scene or --crs" in lines[0], lines
        assert "this terrain has none" not in lines[0]
    assert not (tmp_path / "out.csv").exists()


def test_export_in_lon_lat_is_the_geographic_csv_the_reader_reads(run, tmp_path, capture):
    from tankcd_cli.io.trajectory import read_trajectory

    path, rows, _ = capture
    done = run("export", path, "--crs", "EPSG:4326", "-o", "geo.csv")
    assert done.exit_code == 0, done.stderr
    got = _rows(tmp_path / "geo.csv")
    assert list(got[0]) == ["t", "entity", "lon", "lat", "heading_deg", "turret_deg", "gun_deg"]
    loc = np.array([r[3]["location"] for r in rows])
    lon, lat, _ = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:4326", always_xy=True).transform(*loc.T)
    np.testing.assert_allclose([float(r["lon"]) for r in got], lon, atol=1e-9)
    np.testing.assert_allclose([float(r["lat"]) for r in got], lat, atol=1e-9)
    # read back in a CRS: the capture's own conversion, to the export's rounding (the headings through two
    # measurements of the grid's convergence: within 3e-7 deg)
    wkt = pyproj.CRS("EPSG:32632").to_wkt()
    src = [c for c in read_trajectory(path, crs=wkt)]
    back = [c for c in read_trajectory(str(tmp_path / "geo.csv"), crs=wkt)]
    for f, tol in (("t", 1e-9), ("x", 2e-5), ("y", 2e-5), ("yaw_deg", 3e-7), ("turret_deg", 1e-9)):
        a, b = np.concatenate([getattr(c, f) for c in src]), np.concatenate([getattr(c, f) for c in back])
        d = (a - b + 180) % 360 - 180 if f == "yaw_deg" else a - b
        assert np.abs(d).max() <= tol, f
    assert back[0].time_origin == src[0].time_origin
    # a CSV in metres has no CRS to leave
    (tmp_path / "m.csv").write_text("t,x,y,yaw_deg\n0,1,2,3\n")
    metric = run("export", "m.csv", "--crs", "EPSG:4326", "-o", "m_out.csv")
    assert metric.exit_code == 3 and "x, y in metres" in metric.stderr and not (tmp_path / "m_out.csv").exists()


def test_an_export_without_turret_columns_replays_as_its_input(run, tmp_path):
    import json

    store = tmp_path / "flat.asc"
    from tests.conftest import write_asc

    write_asc(store, np.full((60, 120), 10.0))
    (tmp_path / "drive.csv").write_text("t,x,y,yaw_deg\n" + "".join(f"{k},{20 + k},{30},0\n" for k in range(20)))
    done = run("export", "drive.csv", "--crs", "EPSG:32633", "-o", "drive_out.csv")
    assert done.exit_code == 0, done.stderr
    text = (tmp_path / "drive_out.csv").read_text().splitlines()
    assert text[0] == "t,entity,x,y,yaw_deg" and not text[0].startswith("#")  # no clock, no turret: none written
    effects = []
    for source in ("drive.csv", "drive_out.csv"):
        got = run("-q", "replay", source, "--terrain", "flat.asc", "--poses", "p.csv", "--summary", "-")
        assert got.exit_code == 0, got.stderr
        effects.append(json.loads(got.stdout)["effects"])
    assert effects[0] == effects[1] and effects[0]["internal"] is False


def test_an_export_keeps_the_clock_and_replays_together_as_its_source(run, tmp_path):
    from tankcd_cli.io.trajectory import read_trajectory
    from tests.replay.test_clocks import _csv_b, _gpx_a

    _gpx_a(tmp_path / "A.gpx")
    done = run("export", "A.gpx", "--crs", "EPSG:32632", "-o", "A_utm.csv")
    assert done.exit_code == 0, done.stderr
    assert (tmp_path / "A_utm.csv").read_text().startswith("# time_origin: 2026-05-04T10:00:00Z\nt,entity,x,y,yaw_deg\n")
    src = list(read_trajectory(str(tmp_path / "A.gpx"), crs="EPSG:32632"))
    back = list(read_trajectory(str(tmp_path / "A_utm.csv")))
    assert back[0].time_origin == src[0].time_origin and back[0].time_origin is not None
    np.testing.assert_array_equal(np.concatenate([c.t for c in back]), np.concatenate([c.t for c in src]))
    # together with a file of another clock: the same alignment from the export as from the track
    _csv_b(tmp_path / "B.csv")
    for name in ("A.gpx", "A_utm.csv"):
        for a, b in ((name, "B.csv"), ("B.csv", name)):
            from tankcd_cli.io.trajectory import merged_trajectories

            merged = list(merged_trajectories([str(tmp_path / a), str(tmp_path / b)], crs="EPSG:32632"))
            t = np.concatenate([c.t for c in merged])
            names = np.concatenate([c.names() for c in merged])
            assert t[names == "B"][0] == 5.0 and t[names == "A"][0] == 0.0
            assert merged[0].time_origin == src[0].time_origin


def _meeting_capture(path, n=14, hz=5.0, duration=8.0, seed=2):
    """Vehicles driving and turning in a 40 m square (they meet), turrets swinging, as a pcap (ECEF
    positions and DIS orientations of level vehicles, through pyproj)."""
    from tankcd_cli.io.geodesy import enu_basis
    from tests.io import captures as C
    from tests.io.test_dis import T0

    rng = np.random.default_rng(seed)
    to_geo = pyproj.Transformer.from_crs("EPSG:32632", "EPSG:4326", always_xy=True)
    to_ecef = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:4978", always_xy=True)
    x0, y0 = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(10.0, 50.0)
    rows = []
    for e in range(1, n + 1):
        t = np.arange(rng.uniform(0, 1 / hz), duration, 1 / hz)
        yaw = rng.uniform(-np.pi, np.pi) + rng.uniform(-0.2, 0.2) * t
        speed = rng.uniform(3, 8)
        x = x0 + rng.uniform(0, 40) + np.cumsum(speed * np.cos(yaw) / hz)
        y = y0 + rng.uniform(0, 40) + np.cumsum(speed * np.sin(yaw) / hz)
        turret = rng.uniform(-3, 3) + rng.uniform(-0.5, 0.5) * t
        rows += [(t[k], e, x[k], y[k], yaw[k], turret[k]) for k in range(len(t))]
    rows.sort(key=lambda r: r[0])
    t, ent, x, y, yaw, turret = map(np.array, zip(*rows))
    lon, lat = to_geo.transform(x, y)
    yaw = yaw - np.radians(pyproj.Proj("EPSG:32632").get_factors(lon, lat).meridian_convergence)  # ENU yaw
    ex, ey, ez = to_ecef.transform(lon, lat, np.full(len(t), 150.0))
    frames = []
    for k in range(len(t)):
        c, s = np.cos(yaw[k]), np.sin(yaw[k])
        body = enu_basis([lon[k]], [lat[k]])[0].T @ np.array([[c, s, 0], [s, -c, 0], [0, 0, -1]]).T
        psi, theta, phi = np.arctan2(body[1, 0], body[0, 0]), -np.arcsin(body[2, 0]), np.arctan2(body[2, 1], body[2, 2])
        pdu = C.es_dis7_by_hand(1, 1, int(ent[k]), (ex[k], ey[k], ez[k]), (psi, theta, phi),
                                parts=[(C.TURRET_AZIMUTH, float(turret[k])), (C.GUN_ELEVATION, 0.05)])
        frames.append((T0 + float(t[k]), C.ethernet(C.ipv4(C.udp(pdu)))))
    with open(path, "wb") as fh:
        fh.write(C.pcap(frames))


def test_a_capture_and_its_export_give_the_same_contacts_at_the_same_points(run, tmp_path):
    """Level ground: the hulls' vertical edges meet vertical sides (a first contact along a segment, whose
    point no triangle pair alone defines); the capture and its export agree to 1 cm all the same."""
    import json

    from rasterio.transform import from_origin

    x0, y0 = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(10.0, 50.0)
    with rasterio.open(tmp_path / "flat.tif", "w", driver="GTiff", height=20, width=20, count=1, dtype="float32",
                       crs="EPSG:32632", transform=from_origin(x0 - 50, y0 + 150, 10.0, 10.0)) as dst:
        dst.write(np.full((20, 20), 150.0, "float32"), 1)
    _meeting_capture(tmp_path / "meet.pcap")
    assert run("-q", "classify", "flat.tif", "-o", "ground.h5").exit_code == 0
    assert run("-q", "export", "meet.pcap", "--terrain", "ground.h5", "-o", "meet.csv").exit_code == 0
    events = []
    for source in ("meet.pcap", "meet.csv"):
        got = run("-q", "replay", source, "--terrain", "ground.h5", "--poses", "p.csv", "--events", "e.jsonl")
        assert got.exit_code == 0, got.stderr
        events.append([json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()])
    a, b = events
    contacts = [e for e in a if e["kind"] == "vehicle"]
    assert len(contacts) >= 3 and len(a) == len(b)
    for ea, eb in zip(a, b):
        assert {k: v for k, v in ea.items() if k not in ("t", "point", "closing_speed")} == \
            {k: v for k, v in eb.items() if k not in ("t", "point", "closing_speed")}
        assert ea["t"] == pytest.approx(eb["t"], abs=2e-6)
        if "point" in ea:
            assert np.abs(np.subtract(ea["point"], eb["point"])).max() <= 0.01, (ea, eb)
