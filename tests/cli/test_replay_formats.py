"""replay --format and the inputs told by their bytes: a capture on standard input, Wireshark's .cap, gzip."""

import gzip
import shutil

import pytest

from tests.cli.test_export import capture  # noqa: F401 (the fixture)

pytest.importorskip("pyproj")
pytest.importorskip("rasterio")


def test_a_capture_by_any_name_compressed_or_on_standard_input_replays_the_same(run, tmp_path, capture):  # noqa: F811
    path, rows, tif = capture
    assert run("-q", "classify", tif, "-o", "ground.h5").exit_code == 0
    want = run("-q", "replay", path, "--terrain", "ground.h5", "--poses", "want.csv")
    assert want.exit_code == 0, want.stderr
    expected = (tmp_path / "want.csv").read_bytes()
    assert expected.count(b"\n") == len(rows) + 1
    data = open(path, "rb").read()
    shutil.copy(path, tmp_path / "c.cap")
    (tmp_path / "c.pcap.gz").write_bytes(gzip.compress(data))
    shutil.copy(path, tmp_path / "noname")
    cases = [(["c.cap"], None), (["c.pcap.gz"], None), (["noname"], None), (["-", "--format", "pcap"], data),
             (["-"], data), (["-", "--format", "PCAP"], gzip.compress(data)), (["c.cap", "--format", "pcapng"], None)]
    for k, (args, stdin) in enumerate(cases):
        got = run("-q", "replay", *args, "--terrain", "ground.h5", "--poses", f"got{k}.csv", input=stdin)
        assert got.exit_code == 0, (args, got.stderr)
        assert (tmp_path / f"got{k}.csv").read_bytes() == expected, args
    # a CSV named anything, told by --format or by its bytes; GPX on standard input
    export = run("-q", "export", path, "--terrain", "ground.h5", "-o", "e.log")
    assert export.exit_code == 0, export.stderr
    for args in (["e.log"], ["e.log", "--format", "csv"]):
        assert run("-q", "replay", *args, "--terrain", "ground.h5", "--poses", "e.csv").exit_code == 0
    wrong = run("-q", "replay", "e.log", "--format", "pcap", "--terrain", "ground.h5", "--poses", "x.csv")
    assert wrong.exit_code == 3 and "e.log: not a pcap or pcapng capture" in wrong.stderr
    assert run("replay", "c.cap", "--format", "kml", "--terrain", "ground.h5").exit_code == 2
    fleet = run("replay", "c.cap", "noname", "--format", "pcap", "--terrain", "ground.h5", "--out-dir", "out")
    assert fleet.exit_code == 2 and "--format names one input's format" in fleet.stderr


def test_motion_warnings_about_a_capture_name_the_packet(run, tmp_path, capture):  # noqa: F811
    from tests.io import captures as C
    from tests.io.test_dis import T0, ecef

    _, _, tif = capture
    assert run("-q", "classify", tif, "-o", "ground.h5").exit_code == 0
    pdus = [C.es_dis7(1, 1, 1, ecef(10.0 + k * 0.002, 50.0), (0, 0, 0)) for k in range(3)]  # 143 m a second
    (tmp_path / "jump.pcap").write_bytes(C.pcap([(T0 + k, C.ethernet(C.ipv4(C.udp(p)))) for k, p in enumerate(pdus)]))
    got = run("replay", "jump.pcap", "--terrain", "ground.h5", "--poses", "p.csv")
    assert got.exit_code == 0, got.stderr
    assert "jump.pcap: entity '1:1:1': packet 2: 143.3 m/s from packet 1 (143.3 m in 1 s)" in got.stderr
    assert "line" not in got.stderr.split("jump.pcap: entity")[1].split("\n")[0]
