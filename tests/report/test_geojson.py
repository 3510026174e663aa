"""GeoJSON of a review: every coordinate against pyproj's own conversion, RFC 7946's structure, the
rows' times and the pieces of motion."""

import json
import os

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from pyproj import Transformer

from tankcd_cli.errors import InputError
from tankcd_cli.report.geojson import write_geojson
from tankcd_cli.report.review import Review
from tests.report.reviews import UTM33, track, two_vehicles, wkt

DEG = 0.5e-8 + 1e-12  # the file's rounding to 1e-8 deg


def _lonlat(crs, x, y):
    tr = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)  # fresh: not the writer's
    return tr.transform(np.asarray(x, float), np.asarray(y, float))


def _read(review, tmp_path):
    out = tmp_path / "review.geojson"
    write_geojson(review, str(out))
    text = out.read_text()
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"not JSON: {c}"))


def test_structure_is_rfc7946(tmp_path):
    doc = _read(two_vehicles(), tmp_path)
    assert doc["type"] == "FeatureCollection"
    assert "crs" not in doc  # RFC 7946 removed it
    for f in doc["features"]:
        assert f["type"] == "Feature"
        assert set(f) >= {"type", "geometry", "properties"}
        g = f["geometry"]
        assert g["type"] in ("Point", "LineString")
        positions = [g["coordinates"]] if g["type"] == "Point" else g["coordinates"]
        if g["type"] == "LineString":
            assert len(positions) >= 2
        for p in positions:
            assert len(p) in (2, 3)
            assert -180 <= p[0] <= 180 and -90 <= p[1] <= 90
            assert abs(p[0] - 15.0) < 0.01 and abs(p[1] - 49.65) < 0.01  # lon first, then lat


def test_track_vertices_match_pyproj(tmp_path):
    review = two_vehicles()
    doc = _read(review, tmp_path)
    lines = {f["id"]: f for f in doc["features"] if f["properties"].get("kind") in ("track", "position")}
    assert set(lines) == {"vehicle/alpha/0", "vehicle/bravo/0", "vehicle/bravo/1"}
    a = review.track("alpha")
    coords = np.array(lines["vehicle/alpha/0"]["geometry"]["coordinates"])
    lon, lat = _lonlat(UTM33, a.x, a.y)
    assert coords.shape == (len(a), 3)  # every row has z: 3D
    np.testing.assert_allclose(coords[:, 0], lon, rtol=0, atol=DEG)
    np.testing.assert_allclose(coords[:, 1], lat, rtol=0, atol=DEG)
    np.testing.assert_allclose(coords[:, 2], a.z, rtol=0, atol=0.5e-3 + 1e-9)
    props = lines["vehicle/alpha/0"]["properties"]
    np.testing.assert_allclose(props["times"], a.t, rtol=0, atol=0.5e-6)
    assert props["steps"] == a.step.tolist()
    assert props["entity"] == "alpha" and props["t_start"] == a.t[0] and props["t_end"] == a.t[-1]


def test_pieces_split_at_gaps_longer_than_30s(tmp_path):
    review = two_vehicles()
    doc = _read(review, tmp_path)
    b = review.track("bravo")
    first = next(f for f in doc["features"] if f["id"] == "vehicle/bravo/0")
    last = next(f for f in doc["features"] if f["id"] == "vehicle/bravo/1")
    # the row off the terrain stays (its x, y are known); without z on it, the piece is 2D
    g = np.array(first["geometry"]["coordinates"])
    assert g.shape == (10, 2)
    lon, lat = _lonlat(UTM33, b.x, b.y)
    np.testing.assert_allclose(g[:, 0], lon[:10], rtol=0, atol=DEG)
    np.testing.assert_allclose(g[:, 1], lat[:10], rtol=0, atol=DEG)
    assert first["properties"]["times"] == b.t[:10].tolist()
    # one row after a 40 s gap: a Point of kind position
    assert last["geometry"]["type"] == "Point" and last["properties"]["kind"] == "position"
    assert last["properties"]["times"] == [50.0] and last["properties"]["steps"] == [110]
    np.testing.assert_allclose(last["geometry"]["coordinates"], [lon[10], lat[10], 310.0], rtol=0, atol=DEG)


def test_a_gap_of_exactly_30s_does_not_split(tmp_path):
    tr = track("", [0.0, 30.0, 60.0001], [500000.0, 500001, 500002], [5.5e6] * 3)
    doc = _read(Review(tracks=(tr,), events=[], crs_wkt=wkt(UTM33)), tmp_path)
    sizes = [len(f["properties"]["times"]) for f in doc["features"]]
    assert sizes == [2, 1]


def test_events_at_their_point_or_their_vehicle(tmp_path):
    review = two_vehicles()
    doc = _read(review, tmp_path)
    events = [f for f in doc["features"] if f["id"].startswith("event/")]
    assert [f["properties"] for f in events] == review.events  # every field, as written
    for f, ev in zip(events, review.events):
        p = f["geometry"]["coordinates"]
        if "point" in ev:
            lon, lat = _lonlat(UTM33, [ev["point"][0]], [ev["point"][1]])
            assert p[2] == ev["point"][2]
        elif ev["t"] is not None:  # the vehicle's position at its time: linear between its rows
            tr = review.track(ev["entity"])
            k = np.searchsorted(tr.t, ev["t"]) - 1
            w = (ev["t"] - tr.t[k]) / (tr.t[k + 1] - tr.t[k])
            lon, lat = _lonlat(UTM33, [tr.x[k] + w * (tr.x[k + 1] - tr.x[k])], [tr.y[k] + w * (tr.y[k + 1] - tr.y[k])])
            assert len(p) == 2
        else:  # no time: its step's row
            tr = review.track(ev["entity"])
            k = int(np.flatnonzero(tr.step == ev["step"])[0])
            lon, lat = _lonlat(UTM33, [tr.x[k]], [tr.y[k]])
        assert abs(p[0] - lon[0]) <= DEG and abs(p[1] - lat[0]) <= DEG


def test_one_vehicle_events_without_entity_use_the_one_track(tmp_path):
    tr = track("", [0.0, 1.0], [500000.0, 500010.0], [5.5e6, 5.5e6])
    ev = {"step": 0, "t": 0.5, "kind": "terrain", "a": "hull", "b": "terrain", "depth": 0.1}
    doc = _read(Review(tracks=(tr,), events=[ev], crs_wkt=wkt(UTM33)), tmp_path)
    lon, lat = _lonlat(UTM33, [500005.0], [5.5e6])
    p = doc["features"][0]["geometry"]["coordinates"]
    assert abs(p[0] - lon[0]) <= DEG and abs(p[1] - lat[0]) <= DEG


def test_an_event_nowhere_has_null_geometry(tmp_path):
    a = track("a", [0.0, 1.0], [500000.0, 500010.0], [5.5e6, 5.5e6])
    b = track("b", [0.0, 1.0], [500000.0, 500010.0], [5.5e6, 5.5e6])
    ev = {"step": 0, "t": 0.5, "kind": "terrain", "a": "hull", "b": "terrain"}  # two tracks, no entity
    doc = _read(Review(tracks=(a, b), events=[ev], crs_wkt=wkt(UTM33)), tmp_path)
    assert doc["features"][0]["geometry"] is None


def test_no_crs_is_refused_and_nothing_written(tmp_path):
    review = two_vehicles(crs="")
    out = tmp_path / "review.geojson"
    with pytest.raises(InputError, match="no CRS") as err:
        write_geojson(review, str(out))
    assert "\n" not in str(err.value) and str(err.value).startswith("dem.tif: ")
    assert os.listdir(tmp_path) == []


def test_non_finite_times_are_null(tmp_path):
    tr = track("", [np.nan, np.nan], [500000.0, 500010.0], [5.5e6, 5.5e6])
    doc = _read(Review(tracks=(tr,), events=[], crs_wkt=wkt(UTM33)), tmp_path)
    props = doc["features"][0]["properties"]
    assert props["times"] == [None, None] and props["t_start"] is None


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(166000, 834000), st.floats(0, 9.3e6)), min_size=2, max_size=30),
       st.sampled_from(["EPSG:32633", "EPSG:32733", "EPSG:3035", "EPSG:2056"]))
def test_any_positions_match_pyproj(tmp_path_factory, xy, crs):
    xy = np.array(xy)
    if crs == "EPSG:3035":
        xy = xy * [5, 0.6] + [1e6, 1e6]
    if crs == "EPSG:2056":
        xy = xy * [0.3, 0.02] + [2.5e6, 1.1e6]
    tr = track("v", np.arange(len(xy), dtype=float), xy[:, 0], xy[:, 1])
    doc = _read(Review(tracks=(tr,), events=[], crs_wkt=wkt(crs)), tmp_path_factory.mktemp("g"))
    coords = np.array(doc["features"][0]["geometry"]["coordinates"])
    lon, lat = _lonlat(crs, xy[:, 0], xy[:, 1])
    np.testing.assert_allclose(coords[:, 0], lon, rtol=0, atol=DEG)
    np.testing.assert_allclose(coords[:, 1], lat, rtol=0, atol=DEG)


def test_names_of_any_text_stay_json(tmp_path):
    from tankcd_cli.report.czml import write_czml

    name = 'Leo "2" é\n/'
    tr = track(name, [0.0, 1.0], [500000.0, 500010.0], [5.5e6, 5.5e6])
    ev = {"step": 0, "t": 0.5, "kind": "obstacle", "a": "hull", "b": "<wall & \"x\">", "entity": name,
          "point": [500001.0, 5.5e6, 100.0]}
    review = Review(tracks=(tr,), events=[ev], crs_wkt=wkt(UTM33))
    doc = _read(review, tmp_path)
    assert doc["features"][1]["properties"]["entity"] == name and doc["features"][0]["properties"]["b"] == ev["b"]
    write_czml(review, str(tmp_path / "r.czml"))
    packets = json.loads((tmp_path / "r.czml").read_text())
    assert packets[1]["id"] == f"vehicle/{name}" and "&lt;wall &amp;" in packets[2]["description"]
