"""The trajectory reader (tankcd_cli.io.trajectory): every input form as chunks, checked against independent
truths where there are some: Python's csv and float for the cells, datetime arithmetic for ISO times, pyproj
for geographic positions and headings, the captures the DIS tests frame by hand."""

import csv
import io
from datetime import datetime, timezone

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.trajectory import csv_rows as trajectory_csv
from tankcd_cli.io.trajectory import (TrajectoryChunk, TrajectoryReader, export_trajectory, lead_row, read_trajectory,
                                      split_trajectory, trajectory_info)

FIELDS = ("step", "t", "x", "y", "yaw_deg", "turret_deg", "gun_deg", "line", "entity", "piece_start")


def _write(tmp_path, text, name="t.csv"):
    p = tmp_path / name
    p.write_bytes(text.encode() if isinstance(text, str) else text)
    return str(p)


def _joined(chunks) -> dict:
    chunks = list(chunks)
    out = {f: np.concatenate([getattr(c, f) for c in chunks]) if chunks else np.zeros(0) for f in FIELDS}
    out["names"] = chunks[-1].entity_names if chunks else ()
    return out


def _same(a: dict, b: dict):
    for f in FIELDS:
        np.testing.assert_array_equal(a[f], b[f], err_msg=f)
    assert a["names"] == b["names"]


def _error(path, **kw) -> tuple[str, list]:
    """The one-line error and the chunks yielded before it."""
    got = []
    with pytest.raises(InputError) as exc:
        for chunk in read_trajectory(path, **kw):
            got.append(chunk)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg, got


def _exercise_csv(rng, entities=7, rows=400):
    """Rows of several entities interleaved, asynchronous (each its own rate and start), one with one row."""
    out = []
    for k in range(entities):
        n = 1 if k == 3 else int(rng.integers(5, rows // entities * 2))
        t = np.cumsum(rng.uniform(0.0, 0.7, n)) + rng.uniform(0, 5)
        t[rng.random(n) < 0.1] = t[0]  # equal times too
        t = np.maximum.accumulate(t)
        for tt in t:
            out.append((float(tt), f"tank-{k:02d}" if k != 5 else "Ünïcode 5", rng.uniform(-1e3, 1e3),
                        rng.uniform(-1e3, 1e3), rng.uniform(-180, 180), rng.uniform(-180, 180), rng.uniform(-5, 20)))
    order = rng.permutation(len(out))
    by_entity: dict = {}
    for j in order:  # interleave, keeping each entity's rows in their order
        by_entity.setdefault(out[j][1], [])
    per = {e: [r for r in out if r[1] == e] for e in by_entity}
    rows, left = [], {e: 0 for e in per}
    while any(left[e] < len(per[e]) for e in per):
        e = list(per)[int(rng.integers(len(per)))]
        if left[e] < len(per[e]):
            rows.append(per[e][left[e]])
            left[e] += 1
    return rows


def _csv_text(rows, header=("t", "entity", "x", "y", "yaw_deg", "turret_deg", "gun_deg")):
    return ",".join(header) + "\n" + "".join(",".join(repr(v) if isinstance(v, float) else v for v in r) + "\n"
                                             for r in rows)


# -- the trajectory CSV --------------------------------------------------------------------------------------
def test_single_vehicle_rows_are_pythons_floats_and_any_chunking_gives_the_same_rows(tmp_path, monkeypatch):
    rng = np.random.default_rng(1)
    n = 1000
    vals = np.column_stack([np.cumsum(rng.uniform(0, 1, n)), rng.uniform(-1e6, 1e6, n), rng.normal(0, 1e3, n),
                            rng.uniform(-360, 360, n)])
    texts = [[f"{v:.{int(rng.integers(0, 18))}g}" if rng.random() < 0.5 else repr(float(v)) for v in row]
             for row in vals]
    for r in texts:
        r[0] = repr(float(r[0]))
    texts[0][0] = "0"  # t ascending as written
    ts = np.maximum.accumulate([float(r[0]) for r in texts])
    for r, t in zip(texts, ts):
        r[0] = repr(float(t))
    body = "".join(",".join(r) + ("\r\n" if k % 3 == 0 else "\n") + ("\n  \n" if k % 97 == 0 else "")
                   for k, r in enumerate(texts))
    path = _write(tmp_path, "t,x,y,yaw_deg\n" + body)
    truth = [[float(c) for c in row] for row in csv.reader(io.StringIO(body)) if "".join(row).strip()]
    whole = _joined(read_trajectory(path))
    np.testing.assert_array_equal(np.column_stack([whole["t"], whole["x"], whole["y"], whole["yaw_deg"]]), truth)
    assert whole["names"] == ("t",) and not whole["entity"].any() and whole["piece_start"].tolist() == [True] + [
        False] * (n - 1)
    assert whole["step"].tolist() == list(range(n))
    for rows in (1, 2, 7, 64, 999):
        _same(_joined(read_trajectory(path, chunk_rows=rows)), whole)
    monkeypatch.setattr(trajectory_csv, "BLOCK", 13)  # lines straddle the blocks read
    _same(_joined(read_trajectory(path, chunk_rows=50)), whole)


def test_entities_interleaved_and_asynchronous_their_codes_names_and_pieces(tmp_path, monkeypatch):
    rows = _exercise_csv(np.random.default_rng(2))
    path = _write(tmp_path, _csv_text(rows))
    whole = _joined(read_trajectory(path))
    names = whole["names"]
    # names in order of first appearance, codes index them
    firsts = list(dict.fromkeys(r[1] for r in rows))
    assert names == tuple(firsts)
    assert [names[c] for c in whole["entity"]] == [r[1] for r in rows]
    np.testing.assert_array_equal(whole["t"], [r[0] for r in rows])
    np.testing.assert_array_equal(whole["gun_deg"], [r[6] for r in rows])
    seen = set()
    assert whole["piece_start"].tolist() == [not (r[1] in seen or seen.add(r[1])) for r in rows]
    assert sum(1 for r in rows if r[1] == "tank-03") == 1  # one row: a vehicle standing still is valid
    assert (np.diff(whole["t"]) < 0).any()  # across entities time may go back
    chunks = list(read_trajectory(path, chunk_rows=5))
    assert all(c.has_entity and c.has_turret for c in chunks)
    for a, b in zip(chunks, chunks[1:]):  # the names table only grows, codes keep their names
        assert b.entity_names[:len(a.entity_names)] == a.entity_names
    assert all(c.entity.max() < len(c.entity_names) for c in chunks)
    for k in (1, 3, 5, 64):
        _same(_joined(read_trajectory(path, chunk_rows=k)), whole)
    monkeypatch.setattr(trajectory_csv, "BLOCK", 29)
    _same(_joined(read_trajectory(path, chunk_rows=17)), whole)


def test_an_entity_whose_time_goes_back_names_the_line_and_the_entity(tmp_path):
    text = ("t,x,y,yaw_deg,entity\n0,1,2,3,A\n5,1,2,3,B\n1,1,2,3,A\n6,1,2,3,B\n2,1,2,3,A\n"
            "4.0,1,2,3,B\n7,1,2,3,A\n")
    path = _write(tmp_path, text)
    for k in (1, 2, 100):
        msg, got = _error(path, chunk_rows=k)
        assert msg == (f"{path}: line 7: entity 'B': time goes back (4.0 after 6.0 on line 5); each entity's t must "
                       "be non-decreasing")
        assert sum(len(c) for c in got) == 5  # the rows before it were given
    # across entities time may go back (A at 1 after B at 5): no error
    assert sum(len(c) for c in read_trajectory(_write(tmp_path, text.replace("4.0,", "6.5,"), "ok.csv"))) == 7


@pytest.mark.parametrize("cell, fragment", [
    ('"B"', "line 3 column entity: entity id '\"B\"' holds a quote"),
    ("B'x", "line 3 column entity: entity id \"B'x\" holds a quote"),
    ("  ", "line 3 column entity: empty entity id"),
    ("", "line 3 column entity: empty entity id"),
    ("B,C", "line 3: expected 5 columns as in the header, found 6 (an entity id may not hold a comma)"),
    ("a\x0bb", "line 3 column entity: entity id 'a\\x0bb' holds a control character"),
])
def test_bad_entity_ids_are_refused_naming_the_line(tmp_path, cell, fragment):
    path = _write(tmp_path, f"t,x,y,yaw_deg,entity\n0,1,2,3,A\n1,1,2,3,{cell}\n2,1,2,3,A\n")
    msg, got = _error(path)
    assert msg.startswith(path) and fragment in msg, msg
    assert sum(len(c) for c in got) == 1


def test_an_entity_with_a_semicolon_separator_may_not_hold_a_comma(tmp_path):
    msg, _ = _error(_write(tmp_path, "t;x;y;yaw_deg;entity\n0;1;2;3;A,B\n"))
    assert "line 2 column entity: entity id 'A,B' holds a comma" in msg


def test_entity_ids_are_trimmed_and_may_be_any_utf8_text(tmp_path):
    path = _write(tmp_path, "t,x,y,yaw_deg,entity\n0,1,2,3,  Panzer 1 \n1,1,2,3,Т-72 №4\n2,1,2,3,Panzer 1\n")
    got = _joined(read_trajectory(path))
    assert got["names"] == ("Panzer 1", "Т-72 №4") and got["entity"].tolist() == [0, 1, 0]


def test_not_utf8_in_an_ignored_column_or_an_id_names_the_line(tmp_path):
    for cell in (b"ok,\xff\xfe", b"\xff\xfe,ok"):
        path = _write(tmp_path, b"t,x,y,yaw_deg,entity,note\n0,1,2,3,A,x\n1,1,2,3," + cell + b"\n")
        msg, got = _error(path)
        assert msg == f"{path}: line 3: not UTF-8 text (a trajectory is a CSV file)"
        assert sum(len(c) for c in got) == 1


def test_numbers_off_the_fast_path_read_as_python_reads_them(tmp_path):
    cells = ["0.30000000000000004", "1e-310", "123456789012345678901234567890", "-0.0", "1_000", " +5 ", "1E+22",
             "4.9406564584124654e-324", "9007199254740993"]
    body = "".join(f"{k},{c},0,0\n" for k, c in enumerate(cells))
    got = _joined(read_trajectory(_write(tmp_path, "t,x,y,yaw_deg\n" + body)))
    assert got["x"].tolist() == [float(c) for c in cells]
    assert np.signbit(got["x"][3])


# -- logs as people have them --------------------------------------------------------------------------------
def test_comments_blank_lines_header_case_and_blanks(tmp_path):
    text = ("\ufeff# written by a logger\n#  another\n\n   \n  # indented comment\n"
            ' T ,"X", y ,Yaw_Deg , GUN_DEG,Entity \n0,1,2,3,4,a\n\n1,5,6,7,8,b\n')
    path = _write(tmp_path, text)
    reader = read_trajectory(path)
    got = _joined(reader)
    assert got["t"].tolist() == [0, 1] and got["x"].tolist() == [1, 5] and got["gun_deg"].tolist() == [4, 8]
    assert got["turret_deg"].tolist() == [0, 0] and got["line"].tolist() == [7, 9] and got["names"] == ("a", "b")
    assert reader.skipped == {"comment_lines": 3, "blank_lines": 1}
    msg, _ = _error(_write(tmp_path, "t,x,y,yaw_deg\n0,1,2,3\n# a late comment\n", "late.csv"))
    assert "line 3: a comment line after the header (comment lines go before it)" in msg
    msg, _ = _error(_write(tmp_path, "# only a comment\n\n", "c.csv"))
    assert "file is empty after the comment lines" in msg
    msg, _ = _error(_write(tmp_path, "t,T,x,y,yaw_deg\n", "dup.csv"))
    assert "line 1: column t appears twice in the header" in msg


@pytest.mark.parametrize("sep", [";", "\t"])
def test_semicolon_and_tab_separators(tmp_path, sep):
    rows = [["0", "1.5", "2", "3", "A"], ["2026", "-1e3", " 4 ", "5", "B b"]]
    text = sep.join(["t", "x", "y", "yaw_deg", "entity"]) + "\n" + "".join(sep.join(r) + "\n" for r in rows)
    got = _joined(read_trajectory(_write(tmp_path, text)))
    assert got["t"].tolist() == [0, 2026] and got["x"].tolist() == [1.5, -1e3] and got["y"].tolist() == [2, 4]
    assert got["names"] == ("A", "B b")
    msg, _ = _error(_write(tmp_path, text + sep.join(["3", "1,5", "2", "3", "A"]) + "\n", "dec.csv"))
    assert msg.endswith(f"line 4 column x: a decimal comma ('1,5') in a file separated by "
                        f"{'a semicolon' if sep == ';' else 'a tab'}: write the number with a point (1.5, not 1,5)")
    msg, _ = _error(_write(tmp_path, text + "3,1,2,3,A\n", "commas.csv"))
    assert "line 4: expected 5 columns as in the header, found 1" in msg and "this line by a comma" in msg


@pytest.mark.parametrize("header, fragment", [
    ("t x y yaw_deg", "line 1: cannot tell the separator: the header line ('t x y yaw_deg') holds no comma, "
                      "semicolon or tab; separate the columns with commas"),
    ("t,x;y,yaw_deg", "cannot tell the separator: the header holds a comma and a semicolon"),
    ("t,x,y,yaw_deg,a;t;x;y;yaw_deg", "cannot tell the separator: the header line splits into the required columns "
                                    "by a comma and by a semicolon; separate the columns with commas only"),
])
def test_a_separator_that_cannot_be_told_is_refused_naming_the_fix(tmp_path, header, fragment):
    msg, _ = _error(_write(tmp_path, header + "\n0 1 2 3\n"))
    assert fragment in msg, msg


def test_a_separator_the_header_holds_beside_another_is_the_one_that_splits_it(tmp_path):
    got = _joined(read_trajectory(_write(tmp_path, "t;x;y;yaw_deg;note, with a comma\n0;1;2;3;a, b\n")))
    assert got["x"].tolist() == [1]


ISO = ["2026-05-04T10:00:00.25Z", "2026-05-04T10:00:00.5+00:00", "2026-05-04T12:00:01+02:00",
       "2026-05-04T05:30:01.123456-04:30", "2026-05-04 10:00:02.000000001Z", "2026-05-04t10:00:03z",
       "2026-05-04T11:00:03.75+0100", "2026-05-04T13:00:04+03", "2026-05-05T00:00:00", "2028-02-29T23:59:59.999Z"]


def _py_instant(text):
    """The instant by datetime (nanoseconds beyond microseconds added by hand: datetime keeps microseconds)."""
    core = text[:19]
    rest = text[19:]
    ns = 0
    if rest.startswith("."):
        digits = ""
        for ch in rest[1:]:
            if not ch.isdigit():
                break
            digits += ch
        ns = int(digits.ljust(9, "0"))
        rest = rest[1 + len(digits):]
    zone = rest.replace("z", "Z")
    if zone == "Z" or zone == "":
        zone = "+00:00"
    elif len(zone) == 3:
        zone += ":00"
    elif ":" not in zone:
        zone = zone[:3] + ":" + zone[3:]
    return datetime.fromisoformat(core.replace("t", "T").replace(" ", "T") + zone), ns


def test_iso_times_count_seconds_from_the_first_row_as_datetime_does(tmp_path):
    body = "".join(f"{s},1,2,3\n" for s in ISO)
    reader = read_trajectory(_write(tmp_path, "t,x,y,yaw_deg\n" + body))
    got = _joined(reader)
    d0, n0 = _py_instant(ISO[0])
    want = []
    for s in ISO:
        d, ns = _py_instant(s)
        delta = d - d0  # whole seconds and the zones by datetime, the fraction's nanoseconds beside
        assert delta.microseconds == 0
        want.append(((delta.days * 86400 + delta.seconds) * 10 ** 9 + ns - n0) / 1e9)
    assert got["t"].tolist() == want
    assert reader.start == datetime(2026, 5, 4, 10, 0, 0, 250000, tzinfo=timezone.utc)
    # the same when every row goes through the careful reader (a number it alone reads in each row)
    body2 = "".join(f"{s},1_0,2,3\n" for s in ISO)
    assert _joined(read_trajectory(_write(tmp_path, "t,x,y,yaw_deg\n" + body2, "b.csv")))["t"].tolist() == want


def test_the_compiled_and_the_python_iso_readings_agree():
    from tankcd_cli.io._csv_kernels import iso_time
    from tankcd_cli.io.trajectory.csv_rows import iso_seconds

    bad = ["2026-02-29T00:00:00Z", "2026-05-04T24:00:00Z", "2026-05-04T10:60:00Z", "2026-05-04T10:00:60Z",
           "2026-05-04T10:00:00.1234567890Z", "2026-05-04T10:00:00.Z", "2026-05-04T10:00:00+24:00",
           "2026-05-04T10:00:00+02:", "2026-05-04T10:00:00+2", "2026-05-04T10:00:00+02:60", "0000-01-01T00:00:00",
           "2026-5-04T10:00:00Z", "2026-05-04X10:00:00", "2026-05-04T10:00", "2026-05-04", "2026-13-01T00:00:00",
           "2026-05-04T10:00:00ZZ", "2026-05-04T10:00:00 Z", "1.5", ""]
    for s in ISO + bad + ["1970-01-01T00:00:00Z", "1969-12-31T23:59:59.5Z", "0001-01-01T00:00:00+01:00",
                          "9999-12-31T23:59:59.999999999-23:59"]:
        b = s.encode()
        assert iso_time(b) == iso_seconds(b), s
    for s in bad:
        assert iso_seconds(s.encode()) is None, s
    d = datetime(1969, 12, 31, 23, 59, 59, tzinfo=timezone.utc)
    assert iso_seconds(b"1969-12-31T23:59:59.5Z") == (int(d.timestamp()), 500_000_000)


def test_numbers_and_iso_times_mixed_are_refused_naming_the_line(tmp_path):
    msg, got = _error(_write(tmp_path, "t,x,y,yaw_deg\n2026-05-04T10:00:00Z,1,2,3\n5,1,2,3\n"))
    assert "line 3 column t: a number ('5') among ISO 8601 times" in msg and sum(map(len, got)) == 1
    msg, _ = _error(_write(tmp_path, "t,x,y,yaw_deg\n0,1,2,3\n2026-05-04T10:00:00Z,1,2,3\n", "b.csv"))
    assert "line 3 column t: a date and time ('2026-05-04T10:00:00Z') among numbers" in msg
    msg, _ = _error(_write(tmp_path, "t,x,y,yaw_deg\n2026-05-04T10:00:00Z,1,2,3\n2026-02-30T10:00:00Z,1,2,3\n", "c.csv"))
    assert "line 3 column t: not an ISO 8601 time: '2026-02-30T10:00:00Z'" in msg
    msg, _ = _error(_write(tmp_path, "t,x,y,yaw_deg\n2026-05-04T10:00:01Z,1,2,3\n2026-05-04T10:00:00Z,1,2,3\n",
                           "d.csv"))
    assert "line 3 column t: time goes back (-1.0 after 0.0)" in msg


# -- geographic CSV ----------------------------------------------------------------------------------------------
pyproj = pytest.importorskip("pyproj")
GEOD = pyproj.Geod(ellps="WGS84")

# (CRS, lon, lat): zone 32N at its centre and at its east edge (12 E: the largest convergence), zone 33S
PLACES = [("EPSG:32632", 9.0, 50.0), ("EPSG:32632", 11.99, 61.5), ("EPSG:32733", 12.0, -33.9),
          ("EPSG:32733", 17.99, -45.0)]


def _truth_azimuth(crs, x, y, yaw_deg, step=1.0):
    """The true azimuth (deg) of a short step along the grid direction yaw_deg, through pyproj alone."""
    back = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    a = np.radians(yaw_deg)
    lon0, lat0 = back.transform(x - step * np.cos(a) / 2, y - step * np.sin(a) / 2)
    lon1, lat1 = back.transform(x + step * np.cos(a) / 2, y + step * np.sin(a) / 2)
    az, _, _ = GEOD.inv(lon0, lat0, lon1, lat1)
    return np.mod(az, 360)


@pytest.mark.parametrize("crs, lon0, lat0", PLACES)
@pytest.mark.parametrize("column", ["heading_deg", "yaw_deg"])
def test_geographic_csv_converted_positions_and_headings_against_pyproj(tmp_path, crs, lon0, lat0, column):
    rng = np.random.default_rng(4)
    n = 50
    lon = lon0 + rng.uniform(-0.01, 0.01, n) - (0.01 if lon0 % 6 > 5.9 else 0)
    lat = lat0 + rng.uniform(-0.01, 0.01, n)
    heading = rng.uniform(0, 360, n)  # compass bearings
    given = heading if column == "heading_deg" else 90 - heading  # ENU yaw for the same direction
    body = "".join(f"{k * 0.5!r},{a!r},{b!r},{h!r}\n" for k, (a, b, h) in enumerate(zip(lon.tolist(), lat.tolist(),
                                                                                       given.tolist())))
    path = _write(tmp_path, f"t,Lon,LAT,{column}\n" + body)
    wkt = pyproj.CRS(crs).to_wkt()
    got = _joined(read_trajectory(path, crs=wkt, chunk_rows=7))
    x, y = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(lon, lat)
    np.testing.assert_allclose(got["x"], x, rtol=0, atol=1e-6)
    np.testing.assert_allclose(got["y"], y, rtol=0, atol=1e-6)
    az = _truth_azimuth(crs, got["x"], got["y"], got["yaw_deg"])
    err = (az - heading + 180) % 360 - 180
    assert np.abs(err).max() < 1e-5, np.abs(err).max()
    conv = (got["yaw_deg"] - (90 - heading) + 180) % 360 - 180
    if lon0 % 6 > 5.9 and abs(lat0) > 40:
        assert np.abs(conv).min() > 2.0  # the convergence a hand conversion misses: over 2 deg here


def test_geographic_input_on_a_terrain_without_a_crs_is_refused_in_one_line(tmp_path):
    path = _write(tmp_path, "t,lon,lat,heading_deg\n0,10,50,0\n")
    for crs in (None, "", "  "):
        msg, got = _error(path, crs=crs)
        assert not got and msg.startswith(path + ": ") and "this terrain has none" in msg
    gpx = _write(tmp_path, _gpx_text([("a", [[(50.0, 10.0, "2026-05-04T10:00:00Z")]])]), "t.gpx")
    msg, _ = _error(gpx)
    assert msg.startswith(gpx + ": ") and "this terrain has none" in msg


@pytest.mark.parametrize("row, fragment", [
    ("1,180.5,50,0", "line 3 column lon: 180.5 is out of range (-180 to 180 degrees)"),
    ("1,10,-90.01,0", "line 3 column lat: -90.01 is out of range (-90 to 90 degrees)"),
    ("1,10,nan,0", "line 3 column lat: non-finite value 'nan'"),
])
def test_geographic_ranges_name_the_line(tmp_path, row, fragment):
    msg, got = _error(_write(tmp_path, f"t,lon,lat,heading_deg\n0,10,50,0\n{row}\n"), crs="EPSG:32632")
    assert fragment in msg and sum(map(len, got)) == 1


@pytest.mark.parametrize("header, fragment", [
    ("t,lon,lat,heading_deg,yaw_deg", "both heading_deg (a compass bearing) and yaw_deg"),
    ("t,x,y,heading_deg", "lacks the required column yaw_deg (found: t, x, y, heading_deg); heading_deg (a compass "
                          "bearing from true north) goes with lon, lat"),
    ("t,lon,y,yaw_deg", "lacks the required column x (found: t, lon, y, yaw_deg); geographic positions need both"),
])
def test_headers_that_mix_the_frames_are_refused(tmp_path, header, fragment):
    msg, _ = _error(_write(tmp_path, header + "\n"), crs="EPSG:32632")
    assert "line 1: " in msg and fragment in msg, msg


def test_x_y_win_over_lon_lat_where_both_are_given(tmp_path):
    got = _joined(read_trajectory(_write(tmp_path, "t,x,y,lon,lat,yaw_deg\n0,1,2,10,50,3\n")))
    assert got["x"].tolist() == [1] and got["yaw_deg"].tolist() == [3]


# -- GPX ------------------------------------------------------------------------------------------------------
def _gpx_text(tracks):
    """``tracks``: [(name or None, [[(lat, lon, time), ...] per segment])]."""
    out = ['<?xml version="1.0"?>\n<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">\n']
    for name, segs in tracks:
        out.append("<trk>\n" + (f"<name>{name}</name>\n" if name is not None else ""))
        for seg in segs:
            out.append("<trkseg>\n")
            for lat, lon, time in seg:
                out.append(f'<trkpt lat="{lat!r}" lon="{lon!r}"><time>{time}</time></trkpt>\n')
            out.append("</trkseg>\n")
        out.append("</trk>\n")
    return "".join(out) + "</gpx>\n"


def _walk(lon0, lat0, azimuths, steps):
    lon, lat = [lon0], [lat0]
    for az, d in zip(azimuths, steps):
        x, y, _ = GEOD.fwd(lon[-1], lat[-1], az, d)
        lon.append(x)
        lat.append(y)
    return lon, lat


def test_gpx_two_tracks_with_segments_as_entities_and_pieces(tmp_path):
    lon, lat = _walk(11.9, 55.0, [30, 30, 120], [10, 10, 10])
    seg1 = [(b, a, f"2026-05-04T10:00:0{k}Z") for k, (a, b) in enumerate(zip(lon, lat))]
    lon2, lat2 = _walk(11.95, 55.01, [250, 250], [10, 10])
    seg2 = [(b, a, f"2026-05-04T10:01:0{k}Z") for k, (a, b) in enumerate(zip(lon2, lat2))]
    seg3 = [(55.02, 11.97, "2026-05-04T10:02:00Z"), (55.02, 11.97, "2026-05-04T10:02:05Z")]  # never moves
    lon4, lat4 = _walk(11.9, 55.03, [0], [10])
    seg4 = [(b, a, f"2026-05-04T09:59:5{k}Z") for k, (a, b) in enumerate(zip(lon4, lat4))]
    path = _write(tmp_path, _gpx_text([("Alpha, 1st", [seg1, seg2, seg3]), (None, [seg4])]), "t.gpx")
    reader = read_trajectory(path, crs="EPSG:32632", chunk_rows=3)
    chunks = list(reader)
    got = _joined(chunks)
    assert got["names"] == ("Alpha_ 1st", "track2") and reader.where == "trkpt"
    assert got["entity"].tolist() == [0] * 9 + [1] * 2
    assert np.flatnonzero(got["piece_start"]).tolist() == [0, 4, 7, 9]  # each segment's first point
    np.testing.assert_allclose(got["t"], [0, 1, 2, 3, 60, 61, 62, 120, 125, -10, -9])  # from the file's first point
    lons = lon + lon2 + [11.97, 11.97] + lon4
    lats = lat + lat2 + [55.02, 55.02] + lat4
    x, y = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(lons, lats)
    np.testing.assert_allclose(got["x"], x, atol=1e-6)
    np.testing.assert_allclose(got["y"], y, atol=1e-6)
    az = _truth_azimuth("EPSG:32632", got["x"], got["y"], got["yaw_deg"])
    want = [30, 30, 120, 120, 250, 250, 250, 250, 250, 0, 0]  # a still piece keeps its track's last heading
    err = (az - np.array(want) + 180) % 360 - 180
    assert np.abs(err).max() < 1e-4
    assert got["line"].tolist() == list(range(1, 12))  # track points by their number from 1
    assert all(c.where == "trkpt" for c in chunks)
    assert all(not c.has_turret and c.has_entity for c in chunks)
    assert not got["turret_deg"].any() and not got["gun_deg"].any()


def test_gpx_track_whose_segments_go_back_in_time_and_gpx_without_points(tmp_path):
    seg1 = [(50.0, 10.0, "2026-05-04T10:00:00Z"), (50.0001, 10.0, "2026-05-04T10:00:05Z")]
    seg2 = [(50.0002, 10.0, "2026-05-04T10:00:03Z")]
    path = _write(tmp_path, _gpx_text([("a", [seg1, seg2])]), "t.gpx")
    msg, got = _error(path, crs="EPSG:32632")
    assert msg == (f"{path}: trkpt 3 (line 10): track 'a': time goes back (3.0 s after 5.0 s at line 7): a track's "
                   "segments must follow one another in time")
    assert sum(map(len, got)) == 2
    empty = _write(tmp_path, _gpx_text([("a", [])]), "e.gpx")
    msg, _ = _error(empty, crs="EPSG:32632")
    assert msg == f"{empty}: no track points (trk/trkseg/trkpt) in this GPX file"
    still = _write(tmp_path, _gpx_text([("a", [[(50.0, 10.0, "2026-05-04T10:00:00Z")]])]), "s.gpx")
    got = _joined(read_trajectory(still, crs="EPSG:32632"))
    assert got["yaw_deg"].tolist() == [0.0]  # a track that never moves: yaw 0


# -- DIS captures -----------------------------------------------------------------------------------------------
def _capture(tmp_path, frames, name="c.pcap"):
    from tests.io import captures as C

    return _write(tmp_path, C.pcap(frames), name)


def _exercise_capture(tmp_path):
    from tests.io import captures as C
    from tests.io.test_dis import T0, exercise

    rows = exercise()
    frames = [(T0 + 0.05, C.arp())] + [(T0 + 0.1 + t, C.ethernet(C.ipv4(C.udp(pdu)))) for t, _, pdu, _ in rows]
    return _capture(tmp_path, frames), rows


def test_a_capture_of_interleaved_asynchronous_entities_one_late_reads_as_chunks(tmp_path):
    from tankcd_cli.io.dis import read_capture, trajectory_columns

    path, rows = _exercise_capture(tmp_path)
    wkt = pyproj.CRS("EPSG:32632").to_wkt()
    reader = read_trajectory(path, crs=wkt, chunk_rows=4)
    chunks = list(reader)
    got = _joined(chunks)
    assert reader.where == "packet" and all(c.where == "packet" for c in chunks)
    assert reader.skipped == {"not_ip": 1} and reader.counts.entity_states == len(rows)
    assert reader.start == datetime.fromtimestamp(1_780_000_000, timezone.utc).replace(microsecond=50000)
    names = got["names"]
    assert names == ("1:1:1", "1:1:2", "7:3:9")
    assert [names[c] for c in got["entity"]] == [r[1] for r in rows]
    assert got["line"].tolist() == list(range(2, len(rows) + 2))  # packet numbers
    np.testing.assert_allclose(got["t"], [0.05 + r[0] for r in rows], atol=1e-6)
    assert np.flatnonzero(got["piece_start"]).tolist() == [[r[1] for r in rows].index(e) for e in names]
    late = got["entity"] == 2
    assert got["t"][late].min() == pytest.approx(3.45)
    # positions: ECEF through pyproj alone; the rest as trajectory_columns gives them (tested in test_dis)
    loc = np.array([r[3]["location"] for r in rows])
    x, y, _ = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:32632", always_xy=True).transform(*loc.T)
    np.testing.assert_allclose(got["x"], x, atol=1e-4)
    np.testing.assert_allclose(got["y"], y, atol=1e-4)
    states, _ = read_capture(path)
    cols = trajectory_columns(states, wkt)
    np.testing.assert_array_equal(got["yaw_deg"], cols["yaw_deg"])
    np.testing.assert_array_equal(got["turret_deg"], cols["turret_deg"])
    assert all(c.has_turret and c.has_entity for c in chunks)
    for k in (1, 3, 1000):
        _same(_joined(read_trajectory(path, crs=wkt, chunk_rows=k)), got)


def _es(ent, t, parts, lon=10.0, lat=50.0):
    from tests.io import captures as C
    from tests.io.test_dis import ecef

    return C.ethernet(C.ipv4(C.udp(C.es_dis7(1, 1, ent, ecef(lon, lat), (0.1, 0.2, 0.3), parts=parts))))


def test_turret_and_gun_carry_the_entitys_last_value_and_start_at_zero(tmp_path):
    from tests.io import captures as C

    tur, gun = C.TURRET_AZIMUTH, C.GUN_ELEVATION
    frames = [(1.0, _es(1, 0, [])), (1.1, _es(2, 0, [(tur, 0.5), (gun, 0.1)])), (1.2, _es(1, 0, [(gun, 0.2)])),
              (1.3, _es(2, 0, [])), (1.4, _es(1, 0, [(tur, -1.0)])), (1.5, _es(1, 0, []))]
    path = _capture(tmp_path, frames)
    for k in (1, 2, 10):
        got = _joined(read_trajectory(path, crs="EPSG:32632", chunk_rows=k))
        assert got["entity"].tolist() == [0, 1, 0, 1, 0, 0]
        # DIS turns the turret clockwise seen from above: the contract's turret_deg is its negative
        np.testing.assert_allclose(got["turret_deg"], np.degrees([0, -0.5, 0, -0.5, 1.0, 1.0]), atol=1e-5)
        np.testing.assert_allclose(got["gun_deg"], np.degrees([0, 0.1, 0.2, 0.1, 0.2, 0.2]), atol=1e-5)


def test_packets_a_little_out_of_time_order_are_put_in_order_and_far_out_refused(tmp_path):
    times = [0.0, 0.2, 0.1, 0.4, 0.3, 1.0, 0.95, 2.0]
    frames = [(10 + t, _es(1 + k % 2, 0, [])) for k, t in enumerate(times)]
    path = _capture(tmp_path, frames)
    for k in (1, 3, 100):
        got = _joined(read_trajectory(path, crs="EPSG:32632", chunk_rows=k))
        np.testing.assert_allclose(got["t"], sorted(times), atol=1e-6)
        assert got["line"].tolist() == [1, 3, 2, 5, 4, 7, 6, 8]  # each row keeps its packet number
    frames = [(10.0, _es(1, 0, [])), (12.0, _es(1, 0, [])), (14.0, _es(2, 0, [])), (10.5, _es(2, 0, [])),
              (10.6, _es(1, 0, []))]
    path = _capture(tmp_path, frames, "far.pcap")
    msg, got = _error(path, crs="EPSG:32632", chunk_rows=1)
    # entity 1:1:2 at 10.5 s is far behind but its own first row: fine; 1:1:1 at 10.6 after 12.0: refused
    assert msg == (f"{path}: packet 5: entity '1:1:1': capture time goes back 1.400000 s (t 0.6 after 2.0 at "
                   "packet 2): the packet is 3.400000 s behind the capture's latest time (packet 3), more than the 1 s "
                   "this reader puts back in order; sort the capture by time first (Wireshark's reordercap does)")


def _capture_order_reference(t, entity):
    """The order the capture reader's docs define, packet by packet in plain Python: key max(t, latest so
    far - 1 s), rows stably sorted by it, each entity's time checked. Returns (packets out, bad packet or 0)."""
    latest, keys = -np.inf, []
    for tt in t:
        latest = max(latest, tt)
        keys.append(max(tt, latest - 1.0))
    last, out = {}, []
    for i in sorted(range(len(t)), key=lambda i: (keys[i], i)):
        if entity[i] in last and t[i] < last[entity[i]]:
            return out, i + 1
        last[entity[i]] = t[i]
        out.append(i + 1)
    return out, 0


def test_a_captures_order_and_its_refusals_do_not_depend_on_where_the_read_blocks_fall(tmp_path, monkeypatch):
    """Random captures of packets going back in time by up to 3 s, read in blocks of 1 to 1000 PDUs and of
    4 KiB of the file (a back-step straddling blocks): the same rows in the same order and the same error,
    those of the plain-Python reference."""
    from tankcd_cli.io import dis
    from tankcd_cli.io.dis import read_capture

    monkeypatch.setattr(dis.DisCapture.__init__, "__defaults__", (65536, 4096))  # the smallest read
    rng = np.random.default_rng(21)
    errors = 0
    for trial in range(40):
        n = int(rng.integers(5, 60))
        back = rng.choice([0.0, 0.5, 3.0], p=[0.2, 0.4, 0.4])
        t = np.round(np.cumsum(rng.uniform(0, 0.3, n)) - back * (rng.random(n) < 0.15) * rng.random(n), 3)
        ent = rng.integers(1, 4, n)
        frames = [(100 + float(tt), _es(int(e), 0, [], lon=10 + k * 1e-5)) for k, (tt, e) in enumerate(zip(t, ent))]
        path = _capture(tmp_path, frames, f"r{trial}.pcap")
        decoded = read_capture(path)[0].t
        want, bad = _capture_order_reference(decoded.tolist(), ent.tolist())
        errors += bad > 0
        for rows in (1, 2, 3, 7, 1000):
            got, message = [], None
            try:
                for chunk in TrajectoryReader(path, rows, convert=False):
                    got += chunk.line.tolist()
            except InputError as exc:
                message = str(exc)
            assert got == want, (trial, rows)
            assert (message is None) == (bad == 0), (trial, rows, message)
            if bad:
                assert message.startswith(f"{path}: packet {bad}: entity '1:1:{ent[bad - 1]}': capture time goes "
                                          "back"), message
                assert "s behind the capture's latest time (packet " in message
    assert 5 < errors < 35  # both kinds met


def test_duplicate_packets_are_dropped_counted_and_warned(tmp_path):
    from tankcd_cli.errors import SetupWarning
    from tests.io import captures as C
    from tests.io.test_dis import ecef

    tur = C.TURRET_AZIMUTH

    def es(ent, lon, parts=()):
        return C.es_dis7(1, 1, ent, ecef(lon, 50.0), (0.1, 0.2, 0.3), parts=list(parts))

    eth = lambda *pdus: C.ethernet(C.ipv4(C.udp(b"".join(pdus))))  # noqa: E731
    frames = [(1.0, eth(es(1, 10.0, [(tur, 0.5)]))), (1.0, eth(es(1, 10.0, [(tur, 0.5)]))),  # 2: a duplicate
              (1.0, eth(es(2, 10.1))), (1.0, eth(es(1, 10.0, [(tur, 0.5)]))),  # 4: still its entity's row before
              (1.5, eth(es(1, 10.0, [(tur, 0.5)]))),  # the same state later: a row (a vehicle standing)
              (1.5, eth(es(1, 10.0, [(tur, 0.6)]))),  # the same time, another turret: a row
              (2.0, eth(es(2, 10.2), es(2, 10.2))),  # bundled twice in one datagram: one dropped
              (2.0, eth(es(2, 10.2)))]  # 8
    path = _capture(tmp_path, frames)
    for rows in (1, 2, 100):
        reader = TrajectoryReader(path, rows, crs="EPSG:32632")
        with pytest.warns(SetupWarning, match=r"c\.pcap: 4 duplicate Entity State PDUs dropped .* first at packet 2"):
            got = _joined(reader)
        assert got["line"].tolist() == [1, 3, 5, 6, 7]
        assert got["step"].tolist() == list(range(5))
        assert reader.counts.duplicates == 4 and reader.skipped == {"duplicates": 4}
        np.testing.assert_allclose(got["turret_deg"], np.degrees([-0.5, 0, -0.5, -0.6, 0]), atol=1e-5)
    info = trajectory_info(path)
    assert info.rows == 5 and info.skipped == {"duplicates": 4}


def test_snap_length_cuts_are_warned(tmp_path):
    from tankcd_cli.errors import SetupWarning
    from tests.io.test_dis import _snapped

    frame = _es(1, 0, [])
    data = _snapped(frame, len(frame) - 5)
    path = _write(tmp_path, data + _snapped(frame, len(frame))[24:], "s.pcap")
    with pytest.warns(SetupWarning, match=r"s\.pcap: 1 packets were captured shorter than they were sent \(the "
                                          r"capture's snap length\); 1 PDUs in them cut short and not read"):
        got = _joined(read_trajectory(path, crs="EPSG:32632"))
    assert got["line"].tolist() == [2]


def test_capture_refusals_are_the_decoders(tmp_path):
    from tests.io import captures as C

    path = _capture(tmp_path, [(1.0, C.arp())])
    msg, _ = _error(path, crs="EPSG:32632")
    assert "no DIS Entity State PDU in 1 packets" in msg
    msg, _ = _error(path)
    assert "this terrain has none" in msg


# -- one entry: formats, info, export ---------------------------------------------------------------------------
def test_the_format_is_chosen_by_suffix_or_given(tmp_path):
    path, rows = _exercise_capture(tmp_path)
    other = tmp_path / "capture.bin"
    other.write_bytes(open(path, "rb").read())
    got = _joined(read_trajectory(str(other), crs="EPSG:32632", fmt="pcapng"))  # the file's magic decides pcap/ng
    assert len(got["t"]) == len(rows)
    assert read_trajectory("x.GPX").format == "gpx" and read_trajectory("x.pcapng").format == "pcapng"
    assert read_trajectory("x.txt").format == "csv"
    with pytest.raises(ValueError):
        read_trajectory("x.csv", fmt="kml")


def test_info_lists_entities_their_spans_rows_and_what_was_skipped(tmp_path):
    rows = _exercise_csv(np.random.default_rng(6))
    path = _write(tmp_path, "# log\n" + _csv_text(rows))
    info = trajectory_info(path, chunk_rows=13)
    assert info.format == "csv" and info.coordinates == "projected" and info.rows == len(rows) and info.has_entity
    assert info.skipped == {"comment_lines": 1} and info.columns[:2] == ("t", "entity")
    for e in info.entities:
        mine = [(k, r) for k, r in enumerate(rows) if r[1] == e.name]
        assert e.rows == len(mine) and e.pieces == 1
        assert (e.t_first, e.t_last) == (mine[0][1][0], mine[-1][1][0])
        assert (e.first_line, e.last_line) == (mine[0][0] + 3, mine[-1][0] + 3)
    cap, crow = _exercise_capture(tmp_path)
    info = trajectory_info(cap)  # no CRS needed to describe it
    assert info.coordinates == "ecef" and info.where == "packet" and info.skipped == {"not_ip": 1}
    assert [(e.name, e.rows) for e in info.entities] == [("1:1:1", 30), ("1:1:2", 12), ("7:3:9", 3)]
    assert info.entities[2].t_first == pytest.approx(3.45)
    geo = trajectory_info(_write(tmp_path, "t,lon,lat,heading_deg\n0,10,50,0\n", "g.csv"))
    assert geo.coordinates == "geographic" and geo.entities[0].name == "g" and not geo.has_entity


def test_export_writes_the_csv_tankcd_reads_atomically(tmp_path):
    cap, _ = _exercise_capture(tmp_path)
    out = str(tmp_path / "out.csv")
    result = export_trajectory(cap, out, crs="EPSG:32632", chunk_rows=5)
    assert result["rows"] == 45 and result["entities"] == 3 and result["skipped"] == {"not_ip": 1}
    assert open(out).read().splitlines()[:2] == ["# time_origin: 2026-05-28T20:26:40.05Z",
                                                 "t,entity,x,y,yaw_deg,turret_deg,gun_deg"]
    src = _joined(read_trajectory(cap, crs="EPSG:32632"))
    back = _joined(read_trajectory(out))
    assert back["names"] == src["names"] and back["entity"].tolist() == src["entity"].tolist()
    for f, tol in (("t", 1e-9), ("x", 1e-6), ("y", 1e-6), ("yaw_deg", 1e-9), ("turret_deg", 1e-9), ("gun_deg", 1e-9)):
        np.testing.assert_allclose(back[f], src[f], rtol=0, atol=tol * 0.51)
    assert back["piece_start"].tolist() == src["piece_start"].tolist()
    # non-ASCII names take the careful writer; a single-vehicle file is named after its stem
    p = _write(tmp_path, "t,x,y,yaw_deg,entity\n0,1,2,3,Т-72\n", "u.csv")
    export_trajectory(p, str(tmp_path / "u_out.csv"))
    assert open(tmp_path / "u_out.csv", encoding="utf-8").read().splitlines() == [
        "t,entity,x,y,yaw_deg", "0.000000000,Т-72,1.000000,2.000000,3.000000000"]  # no turret, gun: none written
    export_trajectory(_write(tmp_path, "t,x,y,yaw_deg\n0,1,2,3\n", "solo.csv"), str(tmp_path / "s_out.csv"))
    assert open(tmp_path / "s_out.csv").read().splitlines()[1].split(",")[1] == "solo"
    # an error midway leaves nothing at the target
    bad = _write(tmp_path, "t,x,y,yaw_deg\n0,1,2,3\n" + "1,1,2,3\n" * 100 + "0,1,2,3\n", "bad.csv")
    target = tmp_path / "never.csv"
    with pytest.raises(InputError):
        export_trajectory(bad, str(target), chunk_rows=10)
    assert not target.exists() and not list(tmp_path.glob(".tankcd-*"))


# -- parts ------------------------------------------------------------------------------------------------------
def test_parts_with_a_preamble_and_iso_times_read_as_the_whole_file(tmp_path):
    rows = [f"2026-05-04T10:{k // 600:02d}:{(k // 10) % 60:02d}.{k % 10}Z,{500_010 + k * 0.01:.3f},4500010,0"
            for k in range(3000)]
    path = _write(tmp_path, "# a comment\n\nt,x,y,yaw_deg\n" + "\n".join(rows) + "\n")
    whole = _joined(read_trajectory(path, chunk_rows=700))
    assert whole["t"][1] == 0.1 and whole["line"][0] == 4
    for lines in (1000, 333):
        parts = split_trajectory(path, lines)
        assert sum(p.rows for p in parts) == 3000 and parts[0].line_offset == 3
        got = _joined(c for p in parts for c in read_trajectory(path, chunk_rows=700, part=p))
        for f in ("step", "t", "x", "line", "piece_start"):
            np.testing.assert_array_equal(got[f], whole[f], err_msg=f)
        lead = lead_row(path, parts[1])
        assert isinstance(lead, TrajectoryChunk) and len(lead) == 1
        assert lead.step[0] == parts[1].step_offset - 1 and lead.t[0] == whole["t"][parts[1].step_offset - 1]
        assert lead.line[0] == whole["line"][parts[1].step_offset - 1]
        assert lead_row(path, parts[0]) is None


def test_lead_rows_of_an_entity_file_are_each_entitys_last_row_before_the_part(tmp_path):
    rows = _exercise_csv(np.random.default_rng(8), rows=300)
    path = _write(tmp_path, _csv_text(rows))
    whole = _joined(read_trajectory(path))
    parts = split_trajectory(path, 97)
    for part in parts[1:]:
        lead = lead_row(path, part)
        before = {}
        for k in range(part.step_offset):
            before[rows[k][1]] = k
        assert [lead.entity_names[c] for c in lead.entity] == [rows[k][1] for k in sorted(before.values())]
        assert lead.step.tolist() == sorted(before.values())
        np.testing.assert_array_equal(lead.t, whole["t"][sorted(before.values())])
        np.testing.assert_array_equal(lead.line, whole["line"][sorted(before.values())])


def test_split_refuses_what_is_not_a_csv(tmp_path):
    with pytest.raises(InputError, match="only a trajectory CSV is cut into parts"):
        split_trajectory(str(tmp_path / "x.pcap"), 10)


# -- the compiled pass and the careful reader against a plain reading of the rules -------------------------------
def _reference(data: bytes, sep: bytes):
    """The documented rules read line by line in plain Python: (rows, (line, what) of the error or None)."""
    lines = data.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    rows, last = [], {}
    for k, raw in enumerate(lines[1:], start=2):
        body = raw[:-1] if raw.endswith(b"\r") else raw
        if b"\x00" in body:
            return rows, (k, "not a text file")
        try:
            body.decode("utf-8")
        except UnicodeDecodeError:
            return rows, (k, "not UTF-8")
        if not body.strip():
            continue
        if body.lstrip().startswith(b"#"):
            return rows, (k, "a comment line")
        cells = body.split(sep)
        if len(cells) != 5:
            return rows, (k, "expected 5 columns")
        vals = []
        for j in (0, 1, 2, 3):
            try:
                v = float(cells[j])
            except ValueError:
                return rows, (k, "column")
            if not np.isfinite(v):
                return rows, (k, "column")
            vals.append(v)
        ent = cells[4].strip(b" \t")
        if not ent or any(c in ent for c in b"\"',") or any(c < 32 or c == 127 for c in ent):
            return rows, (k, "column entity")
        ent = ent.decode()
        if ent in last and vals[0] < last[ent]:
            return rows, (k, "time goes back")
        last[ent] = vals[0]
        rows.append((vals[0], ent, vals[1], vals[2], vals[3], k))
    return rows, None


FRAGMENTS = ["0", "1.5", "-2.25", "1e3", " 7 ", "0.30000000000000004", "1_0", "123456789012345678", "+.5", "5.",
             "abc", "nan", "", "1,5", "1e", "\x0c3", "1e400"]
NAMES = ["A", "B", " B ", "Ü", "a b", '"q"', "", "x'y", "\x01"]


@pytest.mark.parametrize("seed", range(60))
def test_random_files_read_as_the_plain_rules_say(tmp_path, monkeypatch, seed):
    rng = np.random.default_rng(100 + seed)
    sep = [b",", b";", b"\t"][seed % 3]
    out = [sep.join([b"t", b"x", b"y", b"yaw_deg", b"entity"])]
    t = {n: 0.0 for n in "AB"}
    for _ in range(int(rng.integers(1, 120))):
        u = rng.random()
        if u < 0.05:
            out.append(rng.choice([b"", b"  ", b"\t", b"\r", b"\x0b"]))
            continue
        name = NAMES[int(rng.integers(len(NAMES)))] if rng.random() < 0.02 else "AB"[int(rng.integers(2))]
        key = name.strip() if name.strip() in t else "A"
        step = -0.5 if rng.random() < 0.01 else rng.uniform(0.0, 1.0)
        t[key] += step
        cells = [repr(round(t[key], 3)), f"{rng.uniform(-1e3, 1e3):.4f}", f"{rng.uniform(-1e3, 1e3):.4f}", "90"]
        if rng.random() < 0.02:
            cells[int(rng.integers(4))] = FRAGMENTS[int(rng.integers(len(FRAGMENTS)))]
        row = sep.join(c.encode() for c in cells + [name])
        if rng.random() < 0.005:
            row += sep + b"extra"
        if rng.random() < 0.003:
            row = b"# comment"
        if rng.random() < 0.003:
            row += b"\xff"
        out.append(row + (b"\r" if rng.random() < 0.2 else b""))
    data = b"\n".join(out) + (b"\n" if rng.random() < 0.7 else b"")
    path = _write(tmp_path, data)
    want, error = _reference(data, sep)
    monkeypatch.setattr(trajectory_csv, "BLOCK", int(rng.integers(8, 200)))
    got, message = [], None
    try:
        for chunk in read_trajectory(path, chunk_rows=int(rng.integers(1, 20))):
            got += list(zip(chunk.t.tolist(), chunk.names().tolist(), chunk.x.tolist(), chunk.y.tolist(),
                            chunk.yaw_deg.tolist(), chunk.line.tolist()))
    except InputError as exc:
        message = str(exc)
    assert got == want
    if error is None:
        assert message is None
    else:
        assert message is not None and f"line {error[0]}" in message and error[1] in message, (message, error)


# -- absolute times --------------------------------------------------------------------------------------------
def test_unix_time_and_a_time_origin_comment_give_the_clock(tmp_path):
    from tankcd_cli.io.trajectory import utc_text

    epoch = _write(tmp_path, "unix_time,x,y,yaw_deg\n1778000000.25,1,2,3\n1778000001.75,1,2,3\n", "e.csv")
    chunks = list(read_trajectory(epoch))
    assert chunks[0].time_origin == 1778000000.25 and chunks[0].t.tolist() == [0.0, 1.5]
    assert utc_text(chunks[0].time_origin) == "2026-05-05T16:53:20.25Z"
    # a comment names the instant t counts from: numbers as they are, ISO times from it
    said = _write(tmp_path, "# time_origin: 2026-05-04T12:00:00.5+02:00\nt,x,y,yaw_deg\n2.5,1,2,3\n", "c.csv")
    got = list(read_trajectory(said))
    assert utc_text(got[0].time_origin) == "2026-05-04T10:00:00.5Z" and got[0].t.tolist() == [2.5]
    iso = _write(tmp_path, "# time_origin: 2026-05-04T10:00:00Z\nt,x,y,yaw_deg\n2026-05-04T10:00:03.25Z,1,2,3\n",
                 "i.csv")
    got = list(read_trajectory(iso))
    assert got[0].t.tolist() == [3.25] and utc_text(got[0].time_origin) == "2026-05-04T10:00:00Z"
    # ISO times alone count from the first row, which is the origin; numbers alone have none
    alone = list(read_trajectory(_write(tmp_path, "t,x,y,yaw_deg\n2026-05-04T12:00:01+02:00,1,2,3\n", "a.csv")))
    assert utc_text(alone[0].time_origin) == "2026-05-04T10:00:01Z"
    assert list(read_trajectory(_write(tmp_path, "t,x,y,yaw_deg\n0,1,2,3\n", "n.csv")))[0].time_origin is None
    info = trajectory_info(iso)
    assert info.time_origin == "2026-05-04T10:00:00Z" and info.start == datetime(2026, 5, 4, 10, tzinfo=timezone.utc)


@pytest.mark.parametrize("text, fragment", [
    ("# time_origin: yesterday\nt,x,y,yaw_deg\n0,1,2,3\n", "line 1: time_origin 'yesterday' is not an ISO 8601"),
    ("# time_origin: 2026-05-04T10:00:00Z\n# TIME_ORIGIN: 2026-05-04T10:00:00Z\nt,x,y,yaw_deg\n",
     "line 2: a second time_origin comment"),
    ("t,unix_time,x,y,yaw_deg\n0,1,2,3,4\n", "line 1: the header has both t and unix_time"),
])
def test_clock_declarations_that_cannot_be_read_are_refused_naming_the_line(tmp_path, text, fragment):
    msg, _ = _error(_write(tmp_path, text))
    assert fragment in msg, msg


def test_parts_of_a_unix_time_file_count_from_its_first_row(tmp_path):
    rows = [f"{1778000000 + k * 0.1:.1f},{500_000 + k:.1f},4500000,0" for k in range(2500)]
    path = _write(tmp_path, "unix_time,x,y,yaw_deg\n" + "\n".join(rows) + "\n")
    whole = list(read_trajectory(path, chunk_rows=600))
    parts = split_trajectory(path, 700)
    got = [c for p in parts for c in read_trajectory(path, chunk_rows=600, part=p)]
    np.testing.assert_array_equal(np.concatenate([c.t for c in got]), np.concatenate([c.t for c in whole]))
    assert {c.time_origin for c in got} == {c.time_origin for c in whole} == {1778000000.0}


def test_the_origins_text_reads_back_into_the_same_float():
    from hypothesis import given, settings, strategies as st

    from tankcd_cli.io.trajectory import utc_text

    @settings(max_examples=100, deadline=None)
    @given(st.floats(min_value=1e8, max_value=4e9))
    def check(origin):
        got = trajectory_csv.iso_seconds(utc_text(origin).encode())
        assert trajectory_csv.epoch_seconds(*got) == origin

    check()
    for origin in np.random.default_rng(4).uniform(1.7e9, 1.9e9, 2000).tolist():  # today's dates, densely
        assert trajectory_csv.epoch_seconds(*trajectory_csv.iso_seconds(utc_text(origin).encode())) == origin


def test_lon_lat_without_a_heading_heads_along_the_track_as_gpx_does(tmp_path):
    from tankcd_cli.errors import SetupWarning

    lon, lat = _walk(11.9, 55.0, [30, 30, 120, 0, 250], [10, 10, 0.01, 10, 10])
    lon2, lat2 = _walk(11.95, 55.01, [200, 200], [10, 10])
    t = list(range(6))
    gpx = _write(tmp_path, _gpx_text([("a", [[(b, a, f"2026-05-04T10:00:0{k}Z") for k, (a, b) in
                                              enumerate(zip(lon, lat))]]),
                                      ("b", [[(b, a, f"2026-05-04T10:00:0{k}Z") for k, (a, b) in
                                              enumerate(zip(lon2, lat2))]])]), "t.gpx")
    rows = sorted([(k, "a", lo, la) for k, lo, la in zip(t, lon, lat)] +
                  [(k, "b", lo, la) for k, lo, la in zip(t, lon2, lat2)])  # the entities interleaved in time
    path = _write(tmp_path, "t,entity,lon,lat\n" + "".join(f"{k},{e},{lo!r},{la!r}\n" for k, e, lo, la in rows))
    with pytest.warns(SetupWarning, match="no heading column .* toward its entity's next row"):
        got = _joined(read_trajectory(path, crs="EPSG:32632", chunk_rows=3))
    ref = _joined(read_trajectory(gpx, crs="EPSG:32632"))
    for name in ("a", "b"):
        mine = np.array(got["names"])[got["entity"]] == name
        theirs = np.array(ref["names"])[ref["entity"]] == name
        np.testing.assert_array_equal(got["yaw_deg"][mine], ref["yaw_deg"][theirs])
        np.testing.assert_array_equal(got["x"][mine], ref["x"][theirs])
    # the same in lon, lat: the headings as compass bearings, along the track
    with pytest.warns(SetupWarning):
        geo = _joined(TrajectoryReader(path, lonlat=True))
    assert geo["x"].tolist() == [r[2] for r in rows]
    a = np.array(geo["names"])[geo["entity"]] == "a"
    np.testing.assert_allclose((90 - geo["yaw_deg"][a]) % 360, [30, 30, 30, 0, 250, 250], atol=1e-6)
    solo = _write(tmp_path, "t,lon,lat\n0,10,50\n1,10,50\n", "still.csv")
    with pytest.warns(SetupWarning, match="the track's next row"):
        assert _joined(read_trajectory(solo, crs="EPSG:32632"))["yaw_deg"].tolist() == [0.0, 0.0]  # never moves


def test_an_export_whose_turret_angles_come_late_gets_their_columns(tmp_path):
    from tests.io import captures as C

    tur = C.TURRET_AZIMUTH
    frames = [(1.0 + 0.5 * k, _es(1, 0, [])) for k in range(6)] + [(5.0, _es(1, 0, [(tur, 0.5)]))]  # parts 1.5 s on
    path = _capture(tmp_path, frames)
    out = str(tmp_path / "late.csv")
    export_trajectory(path, out, crs="EPSG:32632", chunk_rows=2)
    lines = open(out).read().splitlines()
    assert lines[1] == "t,entity,x,y,yaw_deg,turret_deg,gun_deg" and len(lines) == 9
    assert float(lines[-1].split(",")[5]) == pytest.approx(np.degrees(-0.5), abs=1e-5)
    early = str(tmp_path / "early.csv")
    export_trajectory(_capture(tmp_path, frames[:6], "none.pcap"), early, crs="EPSG:32632", chunk_rows=2)
    assert open(early).read().splitlines()[1] == "t,entity,x,y,yaw_deg"
    # to standard output, written as it goes: the columns stay as the header said, and a warning says so
    from tankcd_cli.errors import SetupWarning

    with pytest.warns(SetupWarning, match="turret and gun angles from packet 7 on"):
        export_trajectory(path, "-", crs="EPSG:32632", chunk_rows=2)


def test_files_merged_on_their_clocks_count_from_the_earliest_whatever_their_zones(tmp_path):
    from datetime import datetime, timedelta, timezone

    from hypothesis import given, settings, strategies as st

    from tankcd_cli.io.trajectory import merged_trajectories, utc_text

    base = datetime(2026, 5, 4, 10, 0, 0, tzinfo=timezone.utc)

    @settings(max_examples=12, deadline=None)
    @given(st.lists(st.tuples(st.integers(-50_000, 50_000), st.integers(-14, 14), st.integers(1, 4)),
                    min_size=1, max_size=3), st.integers(1, 5))
    def check(files, chunk_rows):
        paths, truth = [], []
        for k, (start_ms, zone, n) in enumerate(files):
            tz = timezone(timedelta(hours=zone))
            instants = [start_ms / 1000 + 0.25 * j for j in range(n)]
            text = "t,x,y,yaw_deg\n" + "".join(
                f"{(base + timedelta(seconds=s)).astimezone(tz).isoformat(timespec='milliseconds')},{j},0,0\n"
                for j, s in enumerate(instants))
            paths.append(_write(tmp_path, text, f"f{k}.csv"))
            truth.append(instants)
        merged = list(merged_trajectories(paths, chunk_rows=chunk_rows))
        first = min(v[0] for v in truth)
        assert {utc_text(c.time_origin) for c in merged} == {utc_text(base.timestamp() + first)}
        t = np.concatenate([c.t for c in merged])
        names = np.concatenate([c.names() for c in merged])
        for k, instants in enumerate(truth):
            np.testing.assert_allclose(t[names == f"f{k}"], np.array(instants) - first, rtol=0, atol=1e-6)

    check()


@pytest.mark.parametrize("gun", ["1e15", "-180.5", "720"])
def test_a_gun_elevation_beyond_a_half_turn_is_bad_input(tmp_path, gun):
    # 1e15 deg of gun elevation between two rows once spun the gun's path check without end (the fuzzer's find)
    from tankcd_cli import api

    path = tmp_path / "gun.csv"
    path.write_text(f"t,x,y,yaw_deg,turret_deg,gun_deg\n0,1,2,0,90,0\n1,2,2,0,90,{gun}\n")
    with pytest.raises(InputError, match=r"line 3 column gun_deg: .* is no gun elevation \(-180 to 180 degrees\)"):
        list(read_trajectory(str(path)))
    with pytest.raises(InputError, match=r"row 1 gun_deg: .* is no gun elevation"):
        list(api.trajectory_chunks({"t": [0.0, 1.0], "x": [1.0, 2.0], "y": [2.0, 2.0], "yaw_deg": [0.0, 0.0],
                                    "gun_deg": [0.0, float(gun)]}))
    edge = tmp_path / "edge.csv"
    edge.write_text("t,x,y,yaw_deg,turret_deg,gun_deg\n0,1,2,0,90,-180\n1,2,2,0,90,180\n")
    assert np.concatenate([c.gun_deg for c in read_trajectory(str(edge))]).tolist() == [-180.0, 180.0]
