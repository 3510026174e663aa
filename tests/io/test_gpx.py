"""GPX tracks written by the test, read by tankcd_cli.io.gpx; values cross-checked with gpxpy where it is
installed; headings against pyproj.Geod's forward problem (points laid out along known azimuths)."""

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.gpx import read_gpx, track_headings

pyproj = pytest.importorskip("pyproj")

GPX11 = '<?xml version="1.0" encoding="UTF-8"?>\n<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1">\n'
GPX10 = '<?xml version="1.0"?>\n<gpx version="1.0" xmlns="http://www.topografix.com/GPX/1/0">\n'


def _gpx(tracks, head=GPX11, extra=""):
    """``tracks``: [(name or None, [[(lat, lon, time text or None, ele or None), ...] per segment])]."""
    out = [head, extra]
    for name, segments in tracks:
        out.append("  <trk>\n")
        if name is not None:
            out.append(f"    <name>{name}</name>\n")
        for seg in segments:
            out.append("    <trkseg>\n")
            for lat, lon, time, ele in seg:
                out.append(f'      <trkpt lat="{lat}" lon="{lon}">\n')
                if ele is not None:
                    out.append(f"        <ele>{ele}</ele>\n")
                if time is not None:
                    out.append(f"        <time>{time}</time>\n")
                out.append("        <extensions><x:time xmlns:x=\"urn:other\">1999-01-01T00:00:00Z</x:time></extensions>\n")
                out.append("      </trkpt>\n")
            out.append("    </trkseg>\n")
        out.append("  </trk>\n")
    out.append("</gpx>\n")
    return "".join(out)


def _write(tmp_path, text, name="t.gpx"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _walk(lon0, lat0, azimuths, steps):
    """Points along geodesic steps of known azimuths (deg) and lengths (m) from (lon0, lat0)."""
    geod = pyproj.Geod(ellps="WGS84")
    lon, lat = [lon0], [lat0]
    for az, d in zip(azimuths, steps):
        x, y, _ = geod.fwd(lon[-1], lat[-1], az, d)
        lon.append(x)
        lat.append(y)
    return lon, lat


def test_tracks_segments_times_and_elevations(tmp_path):
    lon, lat = _walk(10.0, 50.0, [30, 30, 120, 200], [5, 5, 8, 3])
    seg1 = [(repr(la), repr(lo), t, e) for la, lo, t, e in zip(
        lat, lon, ["2026-05-04T10:00:00Z", "2026-05-04T10:00:00.25Z", "2026-05-04T12:00:01.5+02:00",
                   "2026-05-04T10:00:02.123456789Z", "2026-05-04T10:00:03"], [100, None, 101.5, 102, 103])]
    seg2 = [("50.001", "10.001", "2026-05-04T09:59:58Z", None), ("50.001", "10.001", "2026-05-04T09:59:59Z", None)]
    seg3 = [("-33.5", "-70.25", "2026-05-04T11:00:00-05:00", "7")]
    path = _write(tmp_path, _gpx([("alpha", [seg1, seg2]), (None, [seg3])]))
    g = read_gpx(path)
    assert len(g) == 8
    assert g.track.tolist() == [0] * 7 + [1] and g.segment.tolist() == [0] * 5 + [1, 1, 0]
    assert g.piece.tolist() == [0] * 5 + [1, 1, 2]
    assert g.track_names == ["alpha", ""] and g.track_name.tolist() == ["alpha"] * 7 + [""]
    np.testing.assert_allclose(g.t, [0, 0.25, 1.5, 2.123456, 3, -2, -1, 6 * 3600], atol=1e-9)
    assert g.start.isoformat() == "2026-05-04T10:00:00+00:00"
    np.testing.assert_array_equal(g.lon[:5], lon)
    assert g.lat[7] == -33.5 and g.lon[7] == -70.25
    np.testing.assert_array_equal(g.ele, [100, np.nan, 101.5, 102, 103, np.nan, np.nan, 7])
    lines = path and open(path).read().splitlines()
    assert all(lines[k - 1].lstrip().startswith("<trkpt") for k in g.line)
    # headings: along each step; the last point of a segment keeps the one before
    np.testing.assert_allclose(np.degrees(g.heading[:5]), [30, 30, 120, 200, 200], atol=1e-6)
    assert np.isnan(g.heading[5:]).all()  # a segment that never moves, a lone point


def test_gpx_10_and_no_namespace(tmp_path):
    seg = [("1.5", "2.5", "2020-01-01T00:00:00Z", None), ("1.5001", "2.5", "2020-01-01T00:00:01Z", None)]
    for head in (GPX10, '<?xml version="1.0"?>\n<gpx version="1.1">\n'):
        g = read_gpx(_write(tmp_path, _gpx([("x", [seg])], head=head)))
        assert g.lat.tolist() == [1.5, 1.5001] and g.t.tolist() == [0, 1]
        assert np.degrees(g.heading).round(6).tolist() == [0.0, 0.0]


def test_waypoints_routes_and_foreign_elements_are_passed_over(tmp_path):
    extra = ('<wpt lat="1" lon="1"><time>2000-01-01T00:00:00Z</time></wpt>\n'
             '<rte><rtept lat="3" lon="3"><time>2000-01-01T00:00:00Z</time></rtept></rte>\n')
    seg = [("1.5", "2.5", "2020-01-01T00:00:00Z", None)]
    g = read_gpx(_write(tmp_path, _gpx([("x", [seg])], extra=extra)))
    assert g.lat.tolist() == [1.5] and g.t.tolist() == [0.0]


def test_headings_of_points_standing_still():
    """Points that do not move keep the heading before them; the first take the first real one."""
    lon, lat = _walk(-3.0, 40.0, [0, 0, 90, 0, 0, 250], [0.0, 0.01, 10, 0.02, 0.0, 4])
    piece = np.zeros(len(lon), int)
    h = np.degrees(track_headings(lon, lat, piece))
    np.testing.assert_allclose(h, [90, 90, 90, 90, 90, 250, 250], atol=1e-6)
    # two pieces: nothing carries across
    h = np.degrees(track_headings(lon + lon, lat + lat, np.repeat([0, 1], len(lon))))
    np.testing.assert_allclose(h, [90, 90, 90, 90, 90, 250, 250] * 2, atol=1e-6)
    assert track_headings([1.0], [2.0], [0]).tolist() != [0.0]  # one point: NaN


def test_against_gpxpy(tmp_path):
    gpxpy = pytest.importorskip("gpxpy")
    rng = np.random.default_rng(4)
    lon, lat = _walk(151.2, -33.9, rng.uniform(0, 360, 60), rng.uniform(0, 20, 60))
    times = [f"2026-01-02T03:{k // 60:02d}:{k % 60:02d}.{k * 7 % 1000:03d}Z" for k in range(61)]
    segs = [[(f"{la:.8f}", f"{lo:.8f}", tm, f"{k * 0.5:.1f}") for k, (la, lo, tm) in enumerate(zip(lat, lon, times))]]
    segs = [segs[0][:25], segs[0][25:]]
    path = _write(tmp_path, _gpx([("a", segs), ("b", [segs[1][:3]])]))
    g = read_gpx(path)
    with open(path) as fh:
        theirs = gpxpy.parse(fh)
    pts = [(ti, si, p) for ti, trk in enumerate(theirs.tracks) for si, seg in enumerate(trk.segments) for p in seg.points]
    assert len(pts) == len(g)
    assert [p[0] for p in pts] == g.track.tolist() and [p[1] for p in pts] == g.segment.tolist()
    assert [p[2].latitude for p in pts] == g.lat.tolist() and [p[2].longitude for p in pts] == g.lon.tolist()
    assert [p[2].elevation for p in pts] == g.ele.tolist()
    t0 = pts[0][2].time
    np.testing.assert_allclose([(p[2].time - t0).total_seconds() for p in pts], g.t, atol=1e-9)
    assert [t.name for t in theirs.tracks] == g.track_names


# -- bad input -----------------------------------------------------------------------------------------
def test_no_track_points(tmp_path):
    with pytest.raises(InputError, match=r"t\.gpx: no track points"):
        read_gpx(_write(tmp_path, _gpx([("x", [[]])])))


@pytest.mark.parametrize("point,what", [
    (("50", "10", None, None), r"trkpt 2 \(line \d+\): track point has no time"),
    (("95", "10", "2020-01-01T00:00:05Z", None), r"trkpt 2 \(line \d+\): lat 95 is out of range"),
    (("50", "-180.5", "2020-01-01T00:00:05Z", None), r"trkpt 2 \(line \d+\): lon -180.5 is out of range"),
    (("50", "east", "2020-01-01T00:00:05Z", None), r"trkpt 2 \(line \d+\): lon 'east' is not a number"),
    (("nan", "10", "2020-01-01T00:00:05Z", None), r"trkpt 2 \(line \d+\): lat nan is out of range"),
    (("50", "10", "yesterday", None), r"trkpt 2 \(line \d+\): time 'yesterday' is not an ISO 8601"),
    (("50", "10", "2020-01-01T00:00:05Z", "high"), r"trkpt 2 \(line \d+\): ele 'high' is not a number"),
    (("50", "10", "2019-12-31T23:59:59Z", None), r"trkpt 2 \(line \d+\): time goes back within a segment \(-2 s")])
def test_bad_points_name_the_point_and_its_line(tmp_path, point, what):
    seg = [("50", "10", "2020-01-01T00:00:01Z", None), point]
    text = _gpx([("x", [seg])], extra="\n" * 10)
    path = _write(tmp_path, text)
    with pytest.raises(InputError, match=r"t\.gpx: " + what) as info:
        read_gpx(path)
    line = int(str(info.value).split("(line ")[1].split(")")[0])
    assert text.splitlines()[line - 1].lstrip().startswith("<trkpt")


def test_time_may_go_back_between_segments_and_stand_still(tmp_path):
    segs = [[("50", "10", "2020-01-01T00:00:05Z", None), ("50", "10", "2020-01-01T00:00:05Z", None)],
            [("50", "10", "2020-01-01T00:00:01Z", None)]]
    assert read_gpx(_write(tmp_path, _gpx([("x", segs)]))).t.tolist() == [0, 0, -4]


def test_malformed_xml_names_the_line(tmp_path):
    with pytest.raises(InputError, match=r"t\.gpx: line 4: not well-formed XML \(mismatched tag"):
        read_gpx(_write(tmp_path, GPX11 + "<trk><trkseg><trkpt lat='1' lon='2'>\n</trkseg>"))
