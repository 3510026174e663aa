"""CZML of a review: the document's clock, positions against pyproj, and orientations against
directions measured through pyproj's own projected -> ECEF (EPSG:4978) conversion."""

import datetime as dt
import json
import os

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from pyproj import CRS, Transformer

from tankcd_cli.errors import InputError
from tankcd_cli.report.czml import DEFAULT_EPOCH, write_czml
from tankcd_cli.report.review import Review
from tests.report.reviews import UTM33, track, two_vehicles, wkt

DEG = 0.5e-8 + 1e-12


def _read(review, tmp_path):
    out = tmp_path / "review.czml"
    write_czml(review, str(out))
    return json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"not JSON: {c}"))


def _instant(text):
    return dt.datetime.fromisoformat(text.replace("Z", "+00:00"))


def _matrix(yaw, pitch, roll):
    """(3, 3) Rz(yaw) Ry(pitch) Rx(roll), written out here (not the writer's quaternions)."""
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def _rotate(q_xyzw, v):
    """v turned by the unit quaternion (x, y, z, w)."""
    x, y, z, w = q_xyzw
    u = np.array([x, y, z])
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


def _expected_ecef(to_ecef, x, y, z, v):
    """The ECEF direction of a world-frame vector v at (x, y, z): its horizontal part along the
    chord to the point 1 m ahead in the projected CRS, its vertical part along the chord to the
    point 1 m above, both converted by pyproj."""
    p0 = np.array(to_ecef.transform(x, y, z))
    h = np.hypot(v[0], v[1])
    up = np.array(to_ecef.transform(x, y, z + 1.0)) - p0
    up /= np.linalg.norm(up)
    out = v[2] * up
    if h > 1e-12:
        ahead = np.array(to_ecef.transform(x + v[0] / h, y + v[1] / h, z)) - p0
        out = out + h * ahead / np.linalg.norm(ahead)
    return out


def _ecef(crs):
    return Transformer.from_crs(CRS.from_user_input(crs).to_3d(), "EPSG:4978", always_xy=True)


def _packets(doc):
    return {p["id"]: p for p in doc}


def test_document_packet_first_with_a_clock_over_the_rows(tmp_path):
    review = two_vehicles()
    doc = _read(review, tmp_path)
    first = doc[0]
    assert first["id"] == "document" and first["version"] == "1.0"
    start, stop = first["clock"]["interval"].split("/")
    epoch = _instant(DEFAULT_EPOCH)
    assert _instant(start) == epoch + dt.timedelta(seconds=0.0)
    assert _instant(stop) == epoch + dt.timedelta(seconds=50.0)  # bravo's last row
    assert first["clock"]["currentTime"] == start
    assert first["clock"]["range"] == "LOOP_STOP" and first["clock"]["multiplier"] == 1
    assert DEFAULT_EPOCH in first["description"]
    assert [p["id"] for p in doc] == ["document", "vehicle/alpha", "vehicle/bravo"] + [
        f"event/{n}" for n in range(len(review.events))]


def test_time_origin_is_the_epoch(tmp_path):
    origin = "2026-05-04T10:00:00.25Z"
    doc = _packets(_read(two_vehicles(time_origin=origin), tmp_path))
    start, stop = doc["document"]["clock"]["interval"].split("/")
    assert _instant(start) == _instant(origin)
    assert _instant(stop) == _instant(origin) + dt.timedelta(seconds=50)
    assert doc["vehicle/alpha"]["position"]["epoch"] == origin
    ev = doc["event/0"]
    assert _instant(ev["availability"].split("/")[0]) == _instant(origin) + dt.timedelta(seconds=1.75)


def test_positions_match_pyproj_and_skip_rows_off_the_terrain(tmp_path):
    review = two_vehicles()
    doc = _packets(_read(review, tmp_path))
    to_lonlat = Transformer.from_crs(UTM33, "EPSG:4326", always_xy=True)
    for tr in review.tracks:
        p = doc[f"vehicle/{tr.entity}"]
        on = tr.status != 2
        cd = np.array(p["position"]["cartographicDegrees"]).reshape(-1, 4)
        assert len(cd) == on.sum()
        lon, lat = to_lonlat.transform(tr.x[on], tr.y[on])
        np.testing.assert_allclose(cd[:, 0], tr.t[on], rtol=0, atol=0.5e-6)
        np.testing.assert_allclose(cd[:, 1], lon, rtol=0, atol=DEG)
        np.testing.assert_allclose(cd[:, 2], lat, rtol=0, atol=DEG)
        np.testing.assert_allclose(cd[:, 3], tr.z[on], rtol=0, atol=0.5e-3)
        uq = np.array(p["orientation"]["unitQuaternion"]).reshape(-1, 5)
        assert len(uq) == on.sum()
        np.testing.assert_allclose(np.linalg.norm(uq[:, 1:], axis=1), 1.0, atol=1e-8)
        assert p["box"]["dimensions"]["cartesian"] == [review.vehicle_length, review.vehicle_width, 2.2]
    # bravo's two pieces: two intervals of availability
    assert len(doc["vehicle/bravo"]["availability"]) == 2


def test_forward_axis_points_along_the_yaw(tmp_path):
    """+x of the vehicle turned by the CZML quaternion = the ECEF direction to the point 1 m ahead
    along its yaw in the projected CRS (pyproj to EPSG:4978), off the central meridian where the
    grid convergence is large."""
    yaw = np.linspace(-180, 180, 13)
    x = 500000.0 + np.linspace(-300e3, 300e3, 13)
    y = np.full(13, 5.5e6)
    tr = track("v", np.arange(13.0), x, y, z=np.full(13, 250.0), yaw_deg=yaw)
    doc = _packets(_read(Review(tracks=(tr,), events=[], crs_wkt=wkt(UTM33)), tmp_path))
    uq = np.array(doc["vehicle/v"]["orientation"]["unitQuaternion"]).reshape(-1, 5)
    to_ecef = _ecef(UTM33)
    for k in range(13):
        a = np.radians(yaw[k])
        p0 = np.array(to_ecef.transform(x[k], y[k], 250.0))
        p1 = np.array(to_ecef.transform(x[k] + np.cos(a), y[k] + np.sin(a), 250.0))
        want = (p1 - p0) / np.linalg.norm(p1 - p0)
        got = _rotate(uq[k, 1:], np.array([1.0, 0, 0]))
        assert np.linalg.norm(got - want) < 1e-6, k


@settings(max_examples=30, deadline=None)
@given(st.floats(-179, 179), st.floats(-40, 40), st.floats(-40, 40), st.floats(200e3, 800e3), st.floats(1e6, 8e6),
       st.sampled_from(["EPSG:32633", "EPSG:32733", "EPSG:3035"]))
def test_every_axis_against_pyproj(tmp_path_factory, yaw_deg, pitch_deg, roll_deg, x, y, crs):
    if crs == "EPSG:3035":
        x, y = x * 5, y * 0.5 + 1e6
    pitch, roll = np.radians(pitch_deg), np.radians(roll_deg)
    tr = track("v", [0.0], [x], [y], z=[120.0], yaw_deg=[yaw_deg], pitch=[pitch], roll=[roll])
    doc = _packets(_read(Review(tracks=(tr,), events=[], crs_wkt=wkt(crs)), tmp_path_factory.mktemp("c")))
    q = np.array(doc["vehicle/v"]["orientation"]["unitQuaternion"][1:])
    m = _matrix(np.radians(yaw_deg), pitch, roll)
    to_ecef = _ecef(crs)
    # a conformal CRS keeps right angles: every axis; an equal-area one (3035) does not: the
    # forward axis, and the tilt of the up axis
    for axis in range(3) if crs != "EPSG:3035" else (0,):
        want = _expected_ecef(to_ecef, x, y, 120.0, m[:, axis])
        got = _rotate(q, np.eye(3)[axis])
        assert np.linalg.norm(got - want) < 1e-6, axis
    up = _expected_ecef(to_ecef, x, y, 120.0, np.array([0.0, 0, 1]))
    assert abs(_rotate(q, np.array([0.0, 0, 1])) @ up - m[2, 2]) < 1e-6


def test_quaternions_stay_in_one_hemisphere(tmp_path):
    yaw = np.linspace(0, 720, 50)  # two full turns: a pose's qw >= 0 flips sign twice
    tr = track("v", np.arange(50.0), np.full(50, 500000.0), np.full(50, 5.5e6), yaw_deg=yaw)
    doc = _packets(_read(Review(tracks=(tr,), events=[], crs_wkt=wkt(UTM33)), tmp_path))
    uq = np.array(doc["vehicle/v"]["orientation"]["unitQuaternion"]).reshape(-1, 5)[:, 1:]
    assert (np.einsum("ij,ij->i", uq[1:], uq[:-1]) > 0).all()


def test_events_at_their_point_or_their_vehicle(tmp_path):
    review = two_vehicles()
    doc = _packets(_read(review, tmp_path))
    to_lonlat = Transformer.from_crs(UTM33, "EPSG:4326", always_xy=True)
    p0 = review.events[0]["point"]
    lon, lat = to_lonlat.transform(p0[0], p0[1])
    np.testing.assert_allclose(doc["event/0"]["position"]["cartographicDegrees"], [lon, lat, p0[2]], atol=DEG)
    # no point: alpha's position at t = 3.25 (between its rows at 3.0 and 3.5)
    a = review.track("alpha")
    lon, lat = to_lonlat.transform(np.interp(3.25, a.t, a.x), np.interp(3.25, a.t, a.y))
    np.testing.assert_allclose(doc["event/2"]["position"]["cartographicDegrees"][:2], [lon, lat], atol=DEG)
    assert doc["event/0"]["point"]["color"] != doc["event/1"]["point"]["color"]  # coloured by kind
    for n, ev in enumerate(review.events):
        assert ev["kind"] in doc[f"event/{n}"]["description"]
    start, stop = doc["event/1"]["availability"].split("/")
    assert _instant(stop) == _instant(DEFAULT_EPOCH) + dt.timedelta(seconds=50)


@pytest.mark.parametrize("crs, what", [("", "no CRS"), ("EPSG:4326", "geographic")])
def test_refused_and_nothing_written(tmp_path, crs, what):
    out = tmp_path / "review.czml"
    with pytest.raises(InputError, match=what) as err:
        write_czml(two_vehicles(crs=crs), str(out))
    assert "\n" not in str(err.value)
    assert os.listdir(tmp_path) == []
