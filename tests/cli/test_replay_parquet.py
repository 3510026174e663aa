"""replay's Parquet outputs, read back with pyarrow: value for value the CSV and JSON Lines that the same
replay writes (to the decimals those print), for one vehicle and for an exercise, with events of every
kind (obstacle, internal, terrain, vehicle, between rows); typed columns; the metadata against the
sources' own SHA-256; without pyarrow one line, exit 3 and nothing written; atomic; fleets, split
trajectories joined."""

import csv
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import write_asc

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from tankcd_cli.io.parquet import PYARROW_MISSING, event_dicts  # noqa: E402

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"
# the poses CSV's decimals per column (None: text); the events' JSON rounds t to 6 decimals
DECIMALS = {"step": 0, "t": 6, "x": 4, "y": 4, "z": 4, "roll_deg": 5, "pitch_deg": 5, "yaw_deg": 5, "qw": 8,
            "qx": 8, "qy": 8, "qz": 8, "penetration": 4, "gap": 4}
MISSING_LINE = "tankcd: error: {}: " + PYARROW_MISSING + "\n"


def sha256(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def assert_poses_as_the_csv(parquet_path, csv_path):
    """Every column the CSV has, the Parquet has, typed; every value equal to the CSV's cell to its
    decimals; null exactly where the CSV's cell is empty."""
    table = pq.read_table(parquet_path)
    with open(csv_path, newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        rows = list(reader)
    assert sorted(table.column_names) == sorted(header)
    assert table.num_rows == len(rows) > 0
    schema = table.schema
    assert schema.field("step").type == pa.int64()
    for name in header:
        got = table.column(name).to_pylist()
        cells = [r[header.index(name)] for r in rows]
        assert [g is None for g in got] == [c == "" for c in cells], name
        if name not in DECIMALS:
            assert pa.types.is_dictionary(schema.field(name).type), name
            assert got == cells, name
            continue
        if name != "step":
            assert schema.field(name).type == pa.float64(), name
        g = np.array([np.nan if v is None else v for v in got], dtype=float)
        c = np.array([np.nan if v == "" else float(v) for v in cells])
        half = 0.5 * 10.0 ** -DECIMALS[name]
        close = np.isnan(c) | (np.abs(g - c) <= half * (1 + 1e-6))
        assert close.all(), (name, np.flatnonzero(~close)[:5], g[~close][:5], c[~close][:5])
    return table


def assert_events_as_the_jsonl(parquet_path, jsonl_path):
    """The events read back (``event_dicts``) are the JSON Lines' records: the same fields, the same
    values (t to the JSON's 6 decimals; the rest as written)."""
    table = pq.read_table(parquet_path)
    want = [json.loads(line) for line in Path(jsonl_path).read_text().splitlines()]
    got = event_dicts(table)
    assert len(got) == len(want) > 0
    for g, w in zip(got, want):
        assert set(g) == set(w), (g, w)
        for key, value in w.items():
            if key == "t" and value is not None:
                assert abs(g["t"] - value) <= 0.5e-6 * (1 + 1e-9), (g, w)
            else:
                assert g[key] == value, (key, g, w)
    assert table.schema.field("between").type == pa.bool_() and table.schema.field("contacts").type == pa.int32()
    return table, want


def replay_both(run, *args):
    """The same replay twice: to CSV and JSON Lines, and to Parquet."""
    for poses, events in (("p.csv", "e.jsonl"), ("p.parquet", "e.parquet")):
        result = run("replay", *args, "--poses", poses, "--events", events)
        assert result.exit_code == 0, result.stderr


def test_one_vehicle_parquet_is_the_csv_value_for_value_with_events_of_every_kind(run, tmp_path):
    replay_both(run, SAMPLE / "patrol.csv", "--scene", SAMPLE / "scene.toml")
    assert_poses_as_the_csv(tmp_path / "p.parquet", tmp_path / "p.csv")
    _, events = assert_events_as_the_jsonl(tmp_path / "e.parquet", tmp_path / "e.jsonl")
    kinds = {e["kind"] for e in events}
    assert {"obstacle", "internal", "terrain"} <= kinds, kinds
    assert {e["kind"] for e in events if e.get("between")} >= {"obstacle", "internal"}


def _exercise(path):
    """The sample patrol as entity ``patrol``, a tank parked across its path as ``parked`` (contacts
    between the two vehicles beside the patrol's own obstacle, drum and terrain events) and one straying
    off the terrain as ``stray``."""
    with open(SAMPLE / "patrol.csv") as fh:
        reader = csv.DictReader(fh)
        rows = [dict(r, entity="patrol") for r in reader]
    k = 300  # the patrol's row 300: the parked tank stands there, across the way
    x, y, yaw = rows[k]["x"], rows[k]["y"], float(rows[k]["yaw_deg"]) + 90.0
    t_end = rows[-1]["t"]
    parked = [{"t": t, "x": x, "y": y, "yaw_deg": f"{yaw:.3f}", "turret_deg": "0", "gun_deg": "0", "entity": "parked"}
              for t in ("0.00", t_end)]
    # and one that strays off the terrain's west edge: rows without a pose, off_terrain events
    stray = [{"t": t, "x": x0, "y": "4500050", "yaw_deg": "0", "turret_deg": "0", "gun_deg": "0", "entity": "stray"}
             for t, x0 in (("1.00", "500001"), ("2.00", "499990"), ("3.00", "499970"))]
    merged = sorted(rows + parked + stray, key=lambda r: float(r["t"]))  # stable: the patrol's row first at a tie
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, ["t", "entity", "x", "y", "yaw_deg", "turret_deg", "gun_deg"])
        w.writeheader()
        w.writerows(merged)
    return path


def test_an_exercise_parquet_carries_entity_in_poses_and_events_and_is_the_csv(run, tmp_path):
    _exercise(tmp_path / "ex.csv")
    replay_both(run, "ex.csv", "--scene", SAMPLE / "scene.toml")
    poses = assert_poses_as_the_csv(tmp_path / "p.parquet", tmp_path / "p.csv")
    assert set(poses.column("entity").to_pylist()) == {"patrol", "parked", "stray"}
    assert set(poses.column("status").to_pylist()) >= {"ok", "partly_off", "off"}
    table, events = assert_events_as_the_jsonl(tmp_path / "e.parquet", tmp_path / "e.jsonl")
    kinds = {e["kind"] for e in events}
    assert {"obstacle", "internal", "terrain", "vehicle", "off_terrain"} <= kinds, kinds
    assert any(e.get("between") for e in events)
    assert all(e["entity"] in ("patrol", "parked", "stray") for e in events)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    assert vehicle and all((e["a"], e["b"]) == ("parked", "patrol") and "a_part" in e and "point" in e
                           for e in vehicle)
    assert table.column("entity").null_count == 0
    # every field these kinds carry has a typed column: nothing is left to the JSON of extra
    assert table.column("extra").null_count == table.num_rows
    assert table.schema.field("a_step").type == pa.int64() and table.schema.field("closing_speed").type == pa.float64()


def test_metadata_names_the_crs_conventions_version_and_the_sources_by_their_sha256(run, tmp_path):
    from tankcd_cli import __version__

    store = tmp_path / "bf.h5"
    assert run("classify", SAMPLE / "battlefield.asc", "-o", store).exit_code == 0
    traj = tmp_path / "t.csv"
    traj.write_text("".join((SAMPLE / "patrol.csv").read_text().splitlines(keepends=True)[:40]))
    result = run("replay", traj, "--terrain", store, "--matcher", "four_point", "--poses", "p.parquet", "--events",
                 "e.parquet")
    assert result.exit_code == 0, result.stderr
    for table in ("poses", "events"):
        kv = {k.decode(): v.decode() for k, v in pq.read_metadata(tmp_path / f"{table[0]}.parquet").metadata.items()
              if not k.startswith(b"ARROW:")}
        assert kv["tankcd.table"] == table and kv["tankcd.version"] == __version__
        assert kv["tankcd.units"] == "m, s, deg" and "REP 103" in kv["tankcd.conventions"]
        assert kv["tankcd.crs_wkt"] == ""  # the sample grid names no CRS
        assert json.loads(kv["tankcd.replay"]) == {"matcher": "four_point", "escalate": None, "tolerance": None,
                                                   "attitude_tolerance": None, "mode": "continuous",
                                                   "time_origin": None}  # t in seconds: no absolute clock
        sources = json.loads(kv["tankcd.sources"])
        assert sources == [{"role": "trajectory", "path": str(traj), "sha256": sha256(traj)},
                           # a store is not hashed again: its own record of what it was classified from
                           {"role": "terrain", "path": str(store), "source": str(SAMPLE / "battlefield.asc"),
                            "source_sha256": sha256(SAMPLE / "battlefield.asc")}]


def test_the_terrains_crs_is_in_the_metadata(run, tmp_path):
    rasterio = pytest.importorskip("rasterio")
    pyproj = pytest.importorskip("pyproj")
    from affine import Affine

    with rasterio.open(tmp_path / "flat.tif", "w", driver="GTiff", height=60, width=60, count=1, dtype="float32",
                       crs="EPSG:32633", transform=Affine(1.0, 0.0, 500_000.0, 0.0, -1.0, 4_500_060.0)) as dst:
        dst.write(np.full((1, 60, 60), 100.0, dtype=np.float32))
    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n0,500020,4500020,0\n1,500022,4500020,0\n")
    result = run("replay", "t.csv", "--terrain", "flat.tif", "--poses", "p.parquet")
    assert result.exit_code == 0, result.stderr
    meta = pq.read_metadata(tmp_path / "p.parquet").metadata
    assert pyproj.CRS.from_wkt(meta[b"tankcd.crs_wkt"].decode()).to_epsg() == 32633
    terrain = [s for s in json.loads(meta[b"tankcd.sources"]) if s["role"] == "terrain"]
    assert terrain == [{"role": "terrain", "path": "flat.tif", "sha256": sha256(tmp_path / "flat.tif")}]


@pytest.fixture
def flat(tmp_path):
    write_asc(tmp_path / "flat.asc", np.full((40, 40), 100.0))
    (tmp_path / "t.csv").write_text("t,x,y,yaw_deg\n" + "".join(f"{k * 0.5},{10 + k},20,0\n" for k in range(10)))
    return tmp_path


@pytest.mark.parametrize("outputs,named", [
    (["--poses", "p.parquet"], "p.parquet"),
    (["--poses", "p.csv", "--events", "e.parquet"], "e.parquet"),
    (["--poses", "-", "--events", "E.PARQUET"], "E.PARQUET"),
])
def test_without_pyarrow_one_line_names_the_extra_exit_3_nothing_written(run, flat, monkeypatch, outputs, named):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow raises ImportError
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    result = run("replay", "t.csv", "--terrain", "flat.asc", *outputs)
    assert result.exit_code == 3
    assert result.stderr == MISSING_LINE.format(named) and result.stdout == ""
    assert sorted(p.name for p in flat.iterdir()) == ["flat.asc", "t.csv"]
    # CSV and JSON Lines need no pyarrow
    result = run("replay", "t.csv", "--terrain", "flat.asc", "--poses", "p.csv", "--events", "e.jsonl")
    assert result.exit_code == 0, result.stderr
    fleet = run("replay", "t.csv", "--terrain", "flat.asc", "--out-dir", "out", "--out-format", "parquet")
    assert fleet.exit_code == 3 and fleet.stderr.startswith("tankcd: error: ") and fleet.stderr.endswith(
        f"t.poses.parquet: {PYARROW_MISSING}\n") and len(fleet.stderr.splitlines()) == 1
    assert not (flat / "out").exists()


def test_standard_output_stays_csv_beside_a_parquet_events_file(run, flat):
    result = run("replay", "t.csv", "--terrain", "flat.asc", "--events", "e.parquet")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith("step,t,x,y,z,") and len(result.stdout.splitlines()) == 11
    assert pq.read_table(flat / "e.parquet").num_rows == 0  # no event: a valid empty file of the schema


def test_streamed_a_row_group_per_chunk_and_nothing_left_by_a_bad_row_mid_stream(flat):
    from tankcd_cli.errors import InputError
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.world import WorldSpec

    world = WorldSpec(terrain=str(flat / "flat.asc")).load()
    good = flat / "long.csv"
    good.write_text("t,x,y,yaw_deg\n" + "".join(f"{k * 0.1:.1f},{12 + k * 0.01:.2f},20,0\n" for k in range(1000)))
    outputs = ReplayOutputs(str(flat / "p.parquet"), str(flat / "e.parquet"))
    run_replay(world, str(good), outputs, ReplayOptions(chunk_rows=128))
    assert pq.ParquetFile(flat / "p.parquet").num_row_groups == 8  # 1000 rows in chunks of 128
    assert pq.read_table(flat / "p.parquet").column("step").to_pylist() == list(range(1000))
    before = {p: p.read_bytes() for p in (flat / "p.parquet", flat / "e.parquet")}
    bad = flat / "bad.csv"
    lines = good.read_text().splitlines(keepends=True)
    bad.write_text("".join(lines[:900]) + "89.9,oops,20,0\n" + "".join(lines[900:]))  # in the 8th chunk
    with pytest.raises(InputError, match="bad.csv: line 901"):
        run_replay(world, str(bad), outputs, ReplayOptions(chunk_rows=128))
    assert {p: p.read_bytes() for p in before} == before  # the previous outputs untouched
    assert sorted(p.name for p in flat.iterdir()) == ["bad.csv", "e.parquet", "flat.asc", "long.csv", "p.parquet",
                                                      "t.csv"]


def test_the_api_writes_parquet_and_names_an_exercises_files(tmp_path):
    from tankcd_cli import api

    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    lines = (SAMPLE / "patrol.csv").read_text().splitlines(keepends=True)
    a.write_text("".join(lines[:30]))
    b.write_text(lines[0] + "".join(lines[200:230]))
    summary = api.replay_to_files([str(a), str(b)], poses=str(tmp_path / "p.parquet"), events=None,
                                  scene=str(SAMPLE / "scene.toml"))
    table = pq.read_table(tmp_path / "p.parquet")
    assert table.num_rows == summary.rows == 59 and set(table.column("entity").to_pylist()) == {"a", "b"}
    sources = json.loads(pq.read_metadata(tmp_path / "p.parquet").metadata[b"tankcd.sources"])
    assert [s for s in sources if s["role"] == "trajectory"] == [
        {"role": "trajectory", "path": str(a), "sha256": sha256(a)},
        {"role": "trajectory", "path": str(b), "sha256": sha256(b)}]
    assert {s["role"] for s in sources} == {"trajectory", "scene", "obstacle", "terrain"}
    poses, _ = api.replay([str(a), str(b)], scene=str(SAMPLE / "scene.toml"))
    np.testing.assert_array_equal(table.column("z").to_numpy(zero_copy_only=False), poses["z"])


def test_a_fleet_writes_parquet_per_trajectory_and_joins_a_split_one(run, tmp_path):
    lines = (SAMPLE / "patrol.csv").read_text().splitlines(keepends=True)
    (tmp_path / "short.csv").write_text("".join(lines[:200]))
    (tmp_path / "patrol.csv").write_text("".join(lines))
    _exercise(tmp_path / "ex.csv")
    scene = SAMPLE / "scene.toml"
    args = ("replay", "short.csv", "patrol.csv", "ex.csv", "--scene", scene, "--jobs", "2")
    assert run(*args, "--out-dir", "csv").exit_code == 0
    # 1,145 lines in parts of 1,000: patrol.csv is replayed as two parts, joined
    result = run(*args, "--out-dir", "pq", "--out-format", "parquet", "--split-lines", "1000", "--summary")
    assert result.exit_code == 0, result.stderr
    summary = json.loads((tmp_path / "pq" / "fleet.json").read_text())
    assert summary["tasks"] == 4 and summary["ok"] == 3
    for name in ("short", "patrol", "ex"):
        assert_poses_as_the_csv(tmp_path / "pq" / f"{name}.poses.parquet", tmp_path / "csv" / f"{name}.poses.csv")
        assert_events_as_the_jsonl(tmp_path / "pq" / f"{name}.events.parquet",
                                   tmp_path / "csv" / f"{name}.events.jsonl")
    assert sorted(p.name for p in (tmp_path / "pq").iterdir()) == [  # no part left, the terrain classified once
        ".fleet-terrain.h5", "ex.events.parquet", "ex.poses.parquet", "fleet.json", "patrol.events.parquet",
        "patrol.poses.parquet", "short.events.parquet", "short.poses.parquet"]
    # the joined file: the lone replay's rows in two row groups, the whole trajectory's SHA-256 named once
    assert run("replay", tmp_path / "patrol.csv", "--scene", scene, "--poses", "alone.parquet").exit_code == 0
    joined = tmp_path / "pq" / "patrol.poses.parquet"
    assert pq.ParquetFile(joined).num_row_groups == 2
    assert pq.read_table(joined).equals(pq.read_table(tmp_path / "alone.parquet"))
    meta = pq.read_metadata(joined).metadata
    assert meta == pq.read_metadata(tmp_path / "alone.parquet").metadata  # its sources too: the whole file hashed
    sources = json.loads(meta[b"tankcd.sources"])
    assert sources[0] == {"role": "trajectory", "path": str(tmp_path / "patrol.csv"),
                          "sha256": sha256(tmp_path / "patrol.csv")}


def test_a_glob_skips_the_parquet_files_tankcd_wrote(tmp_path):
    from tankcd_cli.replay.fleet import written_by_tankcd
    from tankcd_cli.io.parquet import ParquetTableWriter, output_metadata

    with ParquetTableWriter(str(tmp_path / "ours.parquet"), [("a", "int64")], output_metadata()) as w:
        w.write({"a": [1, 2]})
    pq.write_table(pa.table({"a": [1, 2]}), tmp_path / "theirs.parquet")
    assert written_by_tankcd(str(tmp_path / "ours.parquet"))
    assert not written_by_tankcd(str(tmp_path / "theirs.parquet"))
