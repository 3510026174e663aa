"""Poses CSV: the compiled writer against printf, the columns the library returns equal to what the
file says, and the reader (quaternions or angles, turret and gun columns, rows without a pose)."""

from types import SimpleNamespace

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.geometry.pose import quaternion_from_euler, rotation_matrix
from tankcd_cli.io.poses_csv import COLUMNS, format_rows, format_rows_printf, header, pose_columns, read_poses
from tankcd_cli.matching.match import PLACED_BY, STATUS, match
from tankcd_cli.terrain import synthetic as S
from tankcd_cli.vehicle import vehicle_preset

DECIMALS = dict(zip(COLUMNS, [0, 6, 4, 4, 4, 5, 5, 5, 8, 8, 8, 8, None, None, 4, 4, None]))


def _poses(rng, n):
    return SimpleNamespace(
        position=np.column_stack([5e5 + rng.uniform(0, 500, n), 4.5e6 + rng.uniform(0, 500, n), rng.normal(0, 300, n)]),
        roll=rng.normal(0, 0.3, n), pitch=rng.normal(0, 0.3, n), yaw=rng.uniform(-np.pi, np.pi, n),
        quaternion=rng.normal(0, 0.5, (n, 4)), penetration=np.abs(rng.normal(0, 0.01, n)), gap=rng.exponential(0.1, n),
        region=rng.choice([0, 1, 2, 255], n).astype(np.uint8), matcher=rng.integers(0, len(PLACED_BY), n),
        status=rng.integers(0, len(STATUS), n))


def _cells(text):
    return [line.split(",") for line in text.splitlines()]


@pytest.mark.parametrize("seed", range(5))
def test_compiled_pose_rows_match_printf(seed):
    rng = np.random.default_rng(seed)
    n = 3000
    p = _poses(rng, n)
    p.position[rng.integers(0, n, 20), 2] = np.nan  # no pose: only t, x, y, yaw are written
    p.gap[rng.integers(0, n, 20)] = np.nan  # no measure: penetration and gap both empty
    p.roll[:50] = rng.choice([0.0, -0.0, -1e-12, 1e-12], 50)
    step = np.arange(n) + 10 ** 7
    t = step * 0.1
    fast, slow = _cells(format_rows(step, t, p, PLACED_BY, STATUS)), _cells(format_rows_printf(step, t, p, PLACED_BY, STATUS))
    assert len(fast) == len(slow) == n
    decimals = [0, 6, 4, 4, 4, 5, 5, 5, 8, 8, 8, 8, None, None, 4, 4, None]
    for a, b in zip(fast, slow):
        assert len(a) == len(b) == 17
        for x, y, d in zip(a, b, decimals):
            if d is None or x == "" or y == "":
                assert x == y
            else:  # same value to the last digit; printf may write -0.000 where we write 0.000
                assert x == y or abs(float(x) - float(y)) <= 10.0 ** -d * 1.0001, (x, y)


def test_values_too_large_for_fixed_point_use_printf():
    rng = np.random.default_rng(1)
    p = _poses(rng, 10)
    p.position[3, 2] = 1e15
    text = format_rows(np.arange(10), np.arange(10.0), p, PLACED_BY, STATUS)
    assert text == format_rows_printf(np.arange(10), np.arange(10.0), p, PLACED_BY, STATUS)
    ends = np.zeros(10, np.int64)  # each row's end, by printf's text as by the compiled writer's
    assert format_rows(np.arange(10), np.arange(10.0), p, PLACED_BY, STATUS, row_ends=ends) == text
    np.testing.assert_array_equal(ends, np.cumsum([len(line) + 1 for line in text.split("\n")[:-1]]))


def _matched(n=300, seed=0):
    """Poses as replay makes them, some partly or entirely off the terrain, at UTM-like coordinates."""
    rng = np.random.default_rng(seed)
    Z = np.cumsum(rng.normal(0, 0.1, (41, 41)), axis=0) + 100.0
    surface = S.surface_of(S.dem_terrain(Z, origin=(5e5, 4.5e6)))
    x = 5e5 + rng.uniform(-10, 50, n)
    y = 4.5e6 + rng.uniform(-10, 50, n)
    poses = match(surface, vehicle_preset("t72"), x, y, rng.uniform(-np.pi, np.pi, n), "auto")
    assert {0, 1, 2} <= set(poses.status.tolist())  # ok, partly off and off rows all occur
    step = np.arange(n) + 5
    return step, step * 0.1, poses


def test_header_is_the_columns():
    assert header() == ",".join(COLUMNS) + "\n"
    assert COLUMNS[:3] == ("step", "t", "x") and COLUMNS[-1] == "status" and len(set(COLUMNS)) == 17


def test_pose_columns_equal_what_the_file_says():
    """Every cell of the CSV is the column's value at the file's precision; empty where it is NaN."""
    step, t, poses = _matched()
    cols = pose_columns(step, t, poses)
    assert list(cols) == list(COLUMNS)
    lines = format_rows(step, t, poses, PLACED_BY, STATUS).splitlines()
    assert len(lines) == len(step)
    for i, line in enumerate(lines):
        for name, cell in zip(COLUMNS, line.split(",")):
            value = cols[name][i]
            if DECIMALS[name] is None:
                assert cell == value, (name, i)
            elif cell == "":
                assert np.isnan(value), (name, i)
            else:
                assert float(cell) == pytest.approx(value, rel=0, abs=0.5001 * 10.0 ** -DECIMALS[name]), (name, i)
    off = cols["status"] == "off"
    assert off.any() and (cols["matcher"][off] == "none").all() and np.isnan(cols["z"][off]).all()
    assert np.isfinite(cols["x"]).all() and np.isfinite(cols["yaw_deg"]).all()  # where it was asked for
    assert cols["step"].dtype == np.int64 and set(cols["region"]) <= {"flat", "general", "uneven", "unknown"}


def test_pose_columns_of_nothing_are_empty_and_typed():
    cols = pose_columns(None, None, None)
    assert list(cols) == list(COLUMNS)
    assert all(len(v) == 0 for v in cols.values())
    assert cols["step"].dtype == np.int64 and cols["status"].dtype.kind == "U" and cols["x"].dtype == np.float64


def _write(path, text):
    path.write_text(text)
    return str(path)


def _read(path, **kw):
    chunks = list(read_poses(path, **kw))
    return [np.concatenate([c[i] for c in chunks]) for i in range(7)], len(chunks)


def test_what_replay_writes_collide_reads_back(tmp_path):
    step, t, poses = _matched(seed=1)
    path = _write(tmp_path / "p.csv", header() + format_rows(step, t, poses, PLACED_BY, STATUS))
    (s, tt, R, position, valid, turret, gun), n_chunks = _read(path, chunk_rows=64)
    assert n_chunks == 5
    np.testing.assert_array_equal(s, step)
    np.testing.assert_allclose(tt, t, atol=1e-6)
    posed = poses.status != STATUS.index("off")
    np.testing.assert_array_equal(valid, posed)
    np.testing.assert_allclose(position[valid], poses.position[posed], atol=5e-5)
    np.testing.assert_allclose(R[valid], poses.rotation[posed], atol=1e-7)  # from the quaternion columns
    assert (turret == 0).all() and (gun == 0).all()


def test_angles_alone_give_the_rotation_and_steps_count_across_chunks(tmp_path):
    rng = np.random.default_rng(2)
    n = 50
    roll, pitch, yaw = rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-np.pi, np.pi, n)
    rows = "".join(f"{i},{i + 1},{i + 2},{r!r},{p!r},{y!r}\n" for i, (r, p, y) in
                   enumerate(zip(np.degrees(roll).tolist(), np.degrees(pitch).tolist(), np.degrees(yaw).tolist())))
    path = _write(tmp_path / "a.csv", "x,y,z,roll_deg,pitch_deg,yaw_deg\n" + rows)
    (step, t, R, position, valid, _, _), n_chunks = _read(path, chunk_rows=16)
    assert n_chunks == 4 and step.tolist() == list(range(n)) and np.isnan(t).all() and valid.all()
    np.testing.assert_allclose(R, rotation_matrix(roll, pitch, yaw), atol=1e-12)
    np.testing.assert_array_equal(position[:, 0], np.arange(n))
    # the same rotations as quaternions (either sign): the same matrices
    q = quaternion_from_euler(roll, pitch, yaw) * np.where(rng.random(n) < 0.5, -1, 1)[:, None]
    rows = "".join(f"0,0,0,{w!r},{a!r},{b!r},{c!r}\n" for w, a, b, c in q.tolist())
    path = _write(tmp_path / "q.csv", "x,y,z,qw,qx,qy,qz\n" + rows)
    (_, _, Rq, _, _, _, _), _ = _read(path)
    np.testing.assert_allclose(Rq, R, atol=1e-12)


def test_quaternions_win_over_angles_and_are_renormalised(tmp_path):
    q = (quaternion_from_euler(np.array([0.1]), np.array([0.2]), np.array([0.3]))[0] * (1 + 5e-4)).tolist()  # near unit
    path = _write(tmp_path / "b.csv", "x,y,z,roll_deg,pitch_deg,yaw_deg,qw,qx,qy,qz\n"
                                      f"0,0,0,45,45,45,{q[0]!r},{q[1]!r},{q[2]!r},{q[3]!r}\n")
    (_, _, R, _, _, _, _), _ = _read(path)
    np.testing.assert_allclose(R[0], rotation_matrix(0.1, 0.2, 0.3), atol=1e-12)


def test_turret_and_gun_columns_in_degrees_come_back_in_radians(tmp_path):
    path = _write(tmp_path / "g.csv", "step,x,y,z,yaw_deg,roll_deg,pitch_deg,turret_deg,gun_deg\n"
                                      "7,0,0,0,0,0,0,90,-5\n8,0,0,0,0,0,0,,\n9,0,0,0,0,0,0,-180,10.5\n")
    (step, _, _, _, valid, turret, gun), _ = _read(path)
    assert step.tolist() == [7, 8, 9] and valid.all()
    np.testing.assert_allclose(turret, np.radians([90, 0, -180]))  # an empty cell: the turret forward
    np.testing.assert_allclose(gun, np.radians([-5, 0, 10.5]))


def test_a_row_without_a_pose_is_not_valid(tmp_path):
    path = _write(tmp_path / "o.csv", "step,t,x,y,z,roll_deg,pitch_deg,yaw_deg\n"
                                      "0,0.0,1,2,3,0,0,0\n1,0.1,1,2,,,,0\n2,,1,2,3,0,0,0\n")
    (step, t, _, position, valid, _, _), _ = _read(path)
    assert valid.tolist() == [True, False, True] and step.tolist() == [0, 1, 2]
    assert np.isnan(position[1, 2]) and t[0] == 0.0 and np.isnan(t[2])


@pytest.mark.parametrize("text, message", [
    ("x,y,z,qw,qx,qy,qz\n0,0,0,1,0,0,0\n0,0,0,0.9,0,0,0\n", r"line 3: quaternion is not unit \(norm 0.900000\)"),
    ("x,y,z,yaw_deg\n0,0,0,10\n", "needs roll_deg, pitch_deg, yaw_deg or qw, qx, qy, qz columns"),
    ("t,x,y,yaw_deg\n0,1,2,3\n", "lacks the required column z.*this looks like a trajectory: `tankcd replay`"),
    ("x,y\n0,1\n", "lacks the required column z \\(found: x, y\\)$"),
    ("x,y,z,roll_deg,pitch_deg,yaw_deg\n0,0,zero,0,0,0\n", "line 2 column z: not a number"),
])
def test_what_is_refused(tmp_path, text, message):
    path = _write(tmp_path / "bad.csv", text)
    with pytest.raises(InputError, match=message):
        _read(path)


def test_not_utf8_and_no_file_are_refused(tmp_path):
    path = tmp_path / "latin.csv"
    path.write_bytes("x,y,z,roll_deg,pitch_deg,yaw_deg\n0,0,0,0,0,0\n".encode() + b"\xe9\xff\n")
    with pytest.raises(InputError, match="not UTF-8 text"):
        _read(str(path))
    with pytest.raises(InputError, match="no such file"):
        _read(str(tmp_path / "none.csv"))


from hypothesis import given, settings
from hypothesis import strategies as st

# entity names: any text without commas, quotes or line breaks (docs/formats.md), ASCII or not
_NAME = st.text(st.characters(blacklist_characters=',"\r\n\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029',
                              blacklist_categories=("Cs",)), min_size=1, max_size=12)


@settings(max_examples=40, deadline=None)
@given(names=st.lists(_NAME, min_size=1, max_size=5, unique=True), seed=st.integers(0, 2 ** 16))
def test_entity_names_outside_ascii_read_back_the_same(tmp_path_factory, names, seed):
    import csv

    rng = np.random.default_rng(seed)
    n = 40
    p = _poses(rng, n)
    step, t = np.arange(n), np.arange(n) * 0.1
    entity = rng.integers(0, len(names), n)
    ends = np.zeros(n, np.int64)
    text = format_rows(step, t, p, PLACED_BY, STATUS, entity, names, row_ends=ends)
    # each row's end counts characters of the text: the rows cut by them are the lines
    assert [text[a:b] for a, b in zip(np.r_[0, ends[:-1]], ends)] == text.splitlines(keepends=True)
    path = tmp_path_factory.mktemp("utf8") / "p.csv"
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(header(entity=True) + text)
    with open(path, encoding="utf-8", newline="") as fh:
        read = [row["entity"] for row in csv.DictReader(fh)]
    assert read == [names[k] for k in entity]


def test_utf8_names_in_the_parallel_writer_keep_their_row_ends():
    """Row blocks formatted apart (more than two blocks of rows) and joined: the same ends."""
    rng = np.random.default_rng(3)
    n = 20_000
    p = _poses(rng, n)
    names = ["Т-72 №4", "leopard", "M1 Абрамс 🛡"]
    entity = rng.integers(0, 3, n)
    ends = np.zeros(n, np.int64)
    text = format_rows(np.arange(n), np.arange(n) * 0.1, p, PLACED_BY, STATUS, entity, names, row_ends=ends)
    lines = text.splitlines(keepends=True)
    np.testing.assert_array_equal(ends, np.cumsum([len(line) for line in lines]))
    assert [line.split(",")[1] for line in lines] == [names[k] for k in entity]
