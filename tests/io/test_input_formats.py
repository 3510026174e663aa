"""Trajectory input formats told in one place (tankcd_cli.io.trajectory.formats, by the names
tankcd_cli.io.input_formats keeps): by the format given, the suffix
(after .gz) or the first bytes; gzip-compressed inputs and standard input read as the same rows as the plain
file."""

import gzip
import io
import sys

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io import input_formats as F
from tankcd_cli.io.trajectory import read_trajectory, trajectory_format
from tests.io.test_trajectory import FIELDS, _exercise_capture, _joined, _same, _write

GPX = (b'<?xml version="1.0"?>\n<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1"><trk><name>a</name>'
       b'<trkseg><trkpt lat="50.0" lon="10.0"><time>2026-05-04T10:00:00Z</time></trkpt>'
       b'<trkpt lat="50.0001" lon="10.0"><time>2026-05-04T10:00:01Z</time></trkpt></trkseg></trk></gpx>\n')
CSV = b"t,entity,x,y,yaw_deg\n0,a,1,2,3\n0.5,b,4,5,6\n1,a,1.5,2,3\n"


@pytest.fixture
def capture_bytes(tmp_path):
    path, _ = _exercise_capture(tmp_path)
    return open(path, "rb").read()


def _stdin(monkeypatch, data: bytes):
    class Stdin:
        buffer = io.BytesIO(data)
    monkeypatch.setattr(sys, "stdin", Stdin())


def test_suffixes_magic_numbers_and_the_format_given(tmp_path, capture_bytes):
    pcapng = _write(tmp_path, b"\x0a\x0d\x0d\x0a" + bytes(60), "x.cap")
    cases = {
        "a.csv": (CSV, "csv"), "a.CSV.gz": (gzip.compress(CSV), "csv"), "a.gpx.gz": (gzip.compress(GPX), "gpx"),
        "a.cap": (capture_bytes, "pcap"), "a.cap.gz": (gzip.compress(capture_bytes), "pcap"),
        "noname": (capture_bytes, "pcap"), "track.xml": (GPX, "gpx"), "log": (CSV, "csv"),
        "a.gz": (gzip.compress(capture_bytes), "pcap"), "a.dat": (b"\xef\xbb\xbf  " + GPX, "gpx"),
        "junk.cap": (b"hello world", "pcap"),  # neither magic: the capture reader names what it found
        "a.pcap": (CSV, "pcap"),  # a suffix that names a format decides
    }
    for name, (data, fmt) in cases.items():
        path = _write(tmp_path, data, name)
        got = F.trajectory_input(path)
        assert got.format == fmt, name
        assert got.compressed == data.startswith(b"\x1f\x8b"), name
        assert trajectory_format(path) == fmt
    assert F.trajectory_input(pcapng).format == "pcapng"
    assert F.trajectory_input(str(tmp_path / "a.csv"), "PCAP") == F.TrajectoryInput("pcap", False, "given")
    assert F.trajectory_input(F.with_format(str(tmp_path / "a.csv"), "gpx")).format == "gpx"
    assert F.trajectory_input("missing.csv.gz") == F.TrajectoryInput("csv", True, "suffix")
    assert F.trajectory_input("missing").format == "csv"
    with pytest.raises(ValueError, match="one of csv, gpx, pcap, pcapng"):
        F.trajectory_input("a.csv", "kml")
    # a path carrying its format stays the path it is, through pickling too
    import pickle

    p = pickle.loads(pickle.dumps(F.with_format("runs/a.bin", "pcapng")))
    assert p == "runs/a.bin" and p.input_format == "pcapng" and isinstance(p, str)
    msg = _read_error(_write(tmp_path, b"hello world", "junk.cap"))
    assert "not a pcap or pcapng capture (it starts with bytes 68 65 6c 6c" in msg


def _read_error(path, **kw):
    with pytest.raises(InputError) as exc:
        list(read_trajectory(path, crs="EPSG:32632", **kw))
    return str(exc.value)


def test_gzip_inputs_read_as_the_plain_files(tmp_path, capture_bytes):
    for plain, name in ((capture_bytes, "c.pcap"), (CSV, "e.csv"), (GPX, "g.gpx")):
        a = _write(tmp_path, plain, name)
        b = _write(tmp_path, gzip.compress(plain), name + ".gz")
        c = _write(tmp_path, gzip.compress(plain[:len(plain) // 2]) + gzip.compress(plain[len(plain) // 2:]), "cat.gz")
        for chunk_rows in (2, 1000):
            want = _joined(read_trajectory(a, chunk_rows, crs="EPSG:32632"))
            _same(_joined(read_trajectory(b, chunk_rows, crs="EPSG:32632")), want)
            # two gzip members one after the other (cat a.gz b.gz), the format told inside
            _same(_joined(read_trajectory(c, chunk_rows, crs="EPSG:32632", fmt=name.split(".")[1])), want)
    # a gzip stream cut short, or corrupt: one line naming the file
    data = gzip.compress(capture_bytes)
    cut = _write(tmp_path, data[:len(data) // 2], "cut.pcap.gz")
    assert "cut.pcap.gz: not a whole gzip stream" in _read_error(cut) or "capture ends" in _read_error(cut)
    bad = bytearray(gzip.compress(CSV * 50))
    bad[20:30] = b"\xff" * 10
    msg = _read_error(_write(tmp_path, bytes(bad), "bad.csv.gz"))
    assert msg.startswith(f"{tmp_path / 'bad.csv.gz'}: ") and "\n" not in msg


def test_a_csv_gz_in_parts_reads_as_the_whole(tmp_path):
    from tankcd_cli.io.trajectory import lead_row, split_trajectory

    rows = "".join(f"{k * 0.1:.1f},{k},{2 * k},0\n" for k in range(300))
    plain = _write(tmp_path, "t,x,y,yaw_deg\n" + rows, "p.csv")
    packed = _write(tmp_path, gzip.compress(("t,x,y,yaw_deg\n" + rows).encode()), "p.csv.gz")
    assert split_trajectory(packed, 70) == split_trajectory(plain, 70)
    for part in split_trajectory(packed, 70):
        _same(_joined(read_trajectory(packed, 50, part)), _joined(read_trajectory(plain, 50, part)))
        a, b = lead_row(packed, part), lead_row(plain, part)
        assert (a is None) == (b is None) and (a is None or a.t.tolist() == b.t.tolist())


@pytest.mark.parametrize("packed", [False, True])
def test_standard_input_captures_csv_and_gpx_told_by_their_bytes_or_given(tmp_path, monkeypatch, capture_bytes,
                                                                         packed):
    for data, name, fmt in ((capture_bytes, "c.pcap", "pcap"), (CSV, "e.csv", "csv"), (GPX, "g.gpx", "gpx")):
        want = _joined(read_trajectory(_write(tmp_path, data, name), 3, crs="EPSG:32632"))
        stdin = gzip.compress(data) if packed else data
        for given in (None, fmt):
            _stdin(monkeypatch, stdin)
            reader = read_trajectory("-", 3, crs="EPSG:32632", fmt=given)
            assert reader.format == fmt
            got = _joined(reader)
            for f in FIELDS:
                np.testing.assert_array_equal(got[f], want[f], err_msg=f)


def test_standard_input_errors_name_stdin(monkeypatch):
    _stdin(monkeypatch, b"\xd4\xc3\xb2\xa1" + bytes(20))
    with pytest.raises(InputError, match=r"^<stdin>: no DIS Entity State PDU in 0 packets"):
        list(read_trajectory("-", crs="EPSG:32632"))
