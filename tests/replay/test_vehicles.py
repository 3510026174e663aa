"""Many vehicles in one world: contacts between vehicles against closed forms and a brute-force
oracle; one entity as a lone replay; entities appearing late; windows and chunks cutting contacts."""

import json

import numpy as np
import pytest

from tests.conftest import write_asc

GROUND = 100.0


@pytest.fixture
def flat(tmp_path):
    write_asc(tmp_path / "flat.asc", np.full((80, 160), GROUND))
    (tmp_path / "scene.toml").write_text('[terrain]\npath = "flat.asc"\n\n[vehicle]\npreset = "t72"\n'
                                         'fuel_drums = false\n')
    return tmp_path


def _write(path, rows):
    path.write_text("t,entity,x,y,yaw_deg\n" + "".join(f"{t},{e},{x},{y},{yaw}\n" for t, e, x, y, yaw in rows))


def _replay(run, tmp_path, *extra):
    result = run("replay", "ex.csv", "--scene", "scene.toml", "--poses", "p.csv", "--events", "e.jsonl",
                 "--summary", *extra)
    assert result.exit_code == 0, result.stderr
    events = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    return events, json.loads(result.stderr.strip().splitlines()[-1])


def test_two_tanks_head_on_meet_at_the_closed_form_time(run, flat):
    rows = []
    for k in range(21):
        t = 0.5 * k
        rows += [(t, "A", 10 + 8 * t, 30, 0), (t, "B", 150 - 7 * t, 30, 180)]
    _write(flat / "ex.csv", rows)
    events, summary = _replay(run, flat)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    # the two guns (6.1 m ahead of each origin, level) meet when 10 + 8 t + 6.1 = 150 - 7 t - 6.1
    t = (150 - 10 - 2 * 6.1) / 15
    assert [(e["a"], e["b"], e["a_part"], e["b_part"]) for e in vehicle] == [("A", "B", "gun", "gun")]
    assert vehicle[0]["t"] == pytest.approx(t, abs=1e-3)
    assert vehicle[0]["closing_speed"] == pytest.approx(15.0, rel=1e-3)
    assert vehicle[0]["point"][0] == pytest.approx(10 + 8 * t + 6.1, abs=2e-3)
    assert vehicle[0]["entity"] == "A" and summary["vehicle_contacts"] == 1 and summary["entities"] == 2


@pytest.mark.parametrize("table", ['id = "B"', 'match = "B*"'])
def test_an_entity_table_makes_one_entity_another_vehicle(run, flat, table):
    # B slides sideways at 2 m/s towards A standing still, side by side; B is an M1 by its [[entity]] table,
    # so the hulls (3.46 m and 3.66 m wide, centred) meet when B's origin is 3.56 m from A's (two T-72s: 3.46 m)
    (flat / "scene.toml").write_text((flat / "scene.toml").read_text() + f'\n[[entity]]\n{table}\npreset = "m1"\n')
    rows = []
    for k in range(11):
        t = 0.5 * k
        rows += [(t, "A", 60, 30, 0), (t, "B", 60, 40 - 2 * t, 0)]
    _write(flat / "ex.csv", rows)
    events, _ = _replay(run, flat)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    assert [(e["a"], e["b"], e["a_part"], e["b_part"]) for e in vehicle] == [("A", "B", "hull", "hull")]
    assert vehicle[0]["t"] == pytest.approx((10 - (3.46 + 3.66) / 2) / 2, abs=1e-3)
    assert vehicle[0]["closing_speed"] == pytest.approx(2.0, rel=1e-3)


def test_a_convoy_nose_to_tail_and_a_column_side_by_side_do_not_touch(run, flat):
    rows = []
    gap = 6.1 + 3.43 + 1.0  # 1 m from a gun's muzzle to the hull ahead
    for k in range(11):
        t = 0.5 * k
        for v in range(4):
            rows.append((t, f"convoy{v}", 20 + v * gap + 5 * t, 20, 0))
            rows.append((t, f"column{v}", 20 + 5 * t, 45 + v * (3.46 + 0.1), 0))  # 10 cm between hulls
    _write(flat / "ex.csv", rows)
    events, summary = _replay(run, flat)
    assert [e for e in events if e["kind"] == "vehicle"] == [] and summary["entities"] == 8


def test_a_crossing_shorter_than_an_interval_between_rows(run, flat):
    # B crosses A's path at 20 m/s with rows 1 s apart: at no row do they overlap
    rows = [(0, "A", 60, 30, 0), (1, "A", 62, 30, 0), (0, "B", 61, 14, 90), (1, "B", 61, 34 + 12, 90)]
    _write(flat / "ex.csv", sorted(rows))
    events, _ = _replay(run, flat)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    assert len(vehicle) == 1 and {vehicle[0]["a"], vehicle[0]["b"]} == {"A", "B"}
    assert 0 < vehicle[0]["t"] < 1


def test_an_entity_appears_late_and_exists_from_its_first_row(run, flat):
    # B stands where A passes at t = 2, but B's first row is at t = 3: no contact then;
    # B then stands in A's way back, touching from its first row on: a contact at t = 3
    rows = [(t, "A", 40 + 10 * t, 30, 0) for t in (0, 1, 2, 3, 4)]
    rows += [(3, "B", 70, 30, 90), (4, "B", 70, 30, 90)]
    _write(flat / "ex.csv", sorted(rows))
    events, _ = _replay(run, flat)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    assert [e["t"] for e in vehicle] == [3.0]


def test_one_entity_is_the_lone_replay_plus_its_entity_column(run, flat):
    from pathlib import Path

    sample = Path(__file__).resolve().parents[2] / "sample_data"
    scene = sample / "scene.toml"
    lines = (sample / "patrol.csv").read_text().splitlines()
    (flat / "lone.csv").write_text("\n".join(lines) + "\n")
    (flat / "ex.csv").write_text("\n".join(["entity," + lines[0]] + ["T1," + line for line in lines[1:]]) + "\n")
    alone = run("replay", "lone.csv", "--scene", scene, "--poses", "a.csv", "--events", "a.jsonl")
    together = run("replay", "ex.csv", "--scene", scene, "--poses", "b.csv", "--events", "b.jsonl")
    assert alone.exit_code == 0 and together.exit_code == 0, together.stderr
    a = (flat / "a.csv").read_text().splitlines()
    b = (flat / "b.csv").read_text().splitlines()
    assert b[0] == a[0].replace("step,", "step,entity,", 1)
    assert [line.replace(",", ",T1,", 1) for line in a[1:]] == b[1:]
    ea = [json.loads(line) for line in (flat / "a.jsonl").read_text().splitlines()]
    eb = [json.loads(line) for line in (flat / "b.jsonl").read_text().splitlines()]
    assert [{**e, "entity": "T1"} for e in ea] == eb


def _exercise(rng, n, seconds=6.0, hz=2.0, area=40.0):
    """n vehicles wandering on the flat ground, each its own rate and start: rows in time order."""
    rows = []
    for v in range(n):
        x, y = rng.uniform(20, 20 + area), rng.uniform(15, 15 + area / 2)
        heading = rng.uniform(-180, 180)
        speed = rng.uniform(2, 8)
        turn = rng.uniform(-20, 20)
        start = rng.uniform(0, 1)
        for k in range(int(seconds * hz)):
            t = round(start + k / hz, 3)
            rows.append((t, f"v{v}", round(x, 3), round(y, 3), round(heading, 3)))
            x += speed / hz * np.cos(np.radians(heading))
            y += speed / hz * np.sin(np.radians(heading))
            heading += turn / hz
    return sorted(rows)


def _oracle_pairs(rows, body, samples_per_second=400):
    """The pairs of entities whose vehicles touch at any instant both exist: each vehicle's motion as
    the contract defines it on flat ground (level hull, position and heading interpolated between
    its rows), sampled densely, and at every sample the exact static test of the two shapes (the
    tandem tree walk, which tests/bvh holds equal to every triangle pair)."""
    from tankcd_cli.bvh.build import build_tree
    from tankcd_cli.bvh.query import collide
    from tankcd_cli.geometry.motion import shorter_arc_deg
    from tankcd_cli.geometry.pose import rotation_matrix

    by = {}
    for t, e, x, y, yaw in rows:
        by.setdefault(e, []).append((t, x, y, yaw))
    t0 = min(r[0] for r in rows)
    t1 = max(r[0] for r in rows)
    ts = np.linspace(t0, t1, int((t1 - t0) * samples_per_second) + 1)
    place = {}
    for e, r in by.items():
        r = np.array(r)
        alive = (ts >= r[0, 0]) & (ts <= r[-1, 0])
        yaw = np.concatenate([[r[0, 3]], r[0, 3] + np.cumsum(shorter_arc_deg(r[:-1, 3], r[1:, 3]))])
        place[e] = (alive, np.interp(ts, r[:, 0], r[:, 1]), np.interp(ts, r[:, 0], r[:, 2]),
                    np.radians(np.interp(ts, r[:, 0], yaw)))
    tree = build_tree(np.concatenate([g.tree.triangles for g in body.groups]), k=18)
    names = sorted(place)
    found = set()
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            pa, pb = place[names[a]], place[names[b]]
            both = np.flatnonzero(pa[0] & pb[0] & (np.hypot(pa[1] - pb[1], pa[2] - pb[2]) < 2 * body.radius))
            if len(both) == 0:
                continue
            # a seen from b's frame: both level on the flat ground, so a turn about z and a shift
            rel = pa[3][both] - pb[3][both]
            dx, dy = pa[1][both] - pb[1][both], pa[2][both] - pb[2][both]
            c, s = np.cos(-pb[3][both]), np.sin(-pb[3][both])
            shift = np.column_stack([c * dx - s * dy, s * dx + c * dy, np.zeros(len(both))])
            R = rotation_matrix(np.zeros(len(both)), np.zeros(len(both)), rel)
            if collide(tree, tree, R, shift).hit.any():
                found.add((names[a], names[b]))
    return found


@pytest.mark.parametrize("seed,n,area", [(1, 6, 30.0), (2, 8, 20.0), (3, 5, 12.0)])
def test_the_pairs_in_contact_are_the_brute_force_oracles(run, flat, seed, n, area):
    from tankcd_cli.collision.obstacles import body_of
    from tankcd_cli.scene import MeshPlacement
    from tankcd_cli.vehicle import vehicle_preset

    rows = _exercise(np.random.default_rng(seed), n, area=area)
    _write(flat / "ex.csv", rows)
    events, _ = _replay(run, flat)
    got = {(e["a"], e["b"]) for e in events if e["kind"] == "vehicle"}
    body = body_of(vehicle_preset("t72", fuel_drums=False), None, MeshPlacement())
    want = _oracle_pairs(rows, body)
    assert want, "the exercise should have some contacts"
    assert got == want


def test_windows_and_chunks_cut_no_contact_twice(flat):
    from tankcd_cli.replay import vehicles as engine
    from tankcd_cli.replay.records import ReplayOptions, ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.world import WorldSpec

    rows = _exercise(np.random.default_rng(5), 6, area=15.0, seconds=8.0)
    _write(flat / "ex.csv", rows)
    world = WorldSpec(scene=str(flat / "scene.toml")).load()

    def contacts(chunk_rows, window):
        seen = []
        saved = engine.WINDOW
        engine.WINDOW = window
        try:
            run_replay(world, str(flat / "ex.csv"), ReplayOutputs(None, None), ReplayOptions(chunk_rows=chunk_rows),
                       observe=lambda chunk, poses, evs: seen.extend(e for e in evs if e.kind == "vehicle"))
        finally:
            engine.WINDOW = saved
        return sorted((round(e.t, 6), e.a, e.b) for e in seen)

    whole = contacts(100000, 100.0)
    assert whole
    assert contacts(7, 0.3) == whole == contacts(3, 2.0)


def test_files_together_are_the_same_rows_in_one_file(run, flat):
    rows = _exercise(np.random.default_rng(2), 5, area=20.0)
    _write(flat / "ex.csv", rows)
    one, _ = _replay(run, flat)
    for name in sorted({r[1] for r in rows}):  # each vehicle its own file, named after it
        (flat / f"{name}.csv").write_text("t,x,y,yaw_deg\n" + "".join(f"{t},{x},{y},{yaw}\n" for t, e, x, y, yaw in rows
                                                                         if e == name))
    files = sorted(str(p) for p in flat.glob("v*.csv"))
    result = run("replay", *files, "--together", "--scene", "scene.toml", "--poses", "q.csv", "--events", "f.jsonl")
    assert result.exit_code == 0, result.stderr
    together = [json.loads(line) for line in (flat / "f.jsonl").read_text().splitlines()]
    key = lambda e: (e["kind"], round(e["t"], 6), e["a"], e["b"])  # noqa: E731 (steps count the merged rows)
    assert sorted(map(key, together)) == sorted(map(key, one))
    assert any(e["kind"] == "vehicle" for e in one)
    # the merged poses are the one file's rows, in time order, named as there
    poses_one = sorted((flat / "p.csv").read_text().splitlines()[1:], key=lambda r: r.split(",", 2)[2])
    poses_two = sorted((flat / "q.csv").read_text().splitlines()[1:], key=lambda r: r.split(",", 2)[2])
    assert [r.split(",", 1)[1] for r in poses_one] == [r.split(",", 1)[1] for r in poses_two]


def test_two_files_naming_the_same_entity_are_bad_input(run, flat):
    (flat / "a.csv").write_text("t,entity,x,y,yaw_deg\n0,T1,40,30,0\n")
    (flat / "b.csv").write_text("t,entity,x,y,yaw_deg\n0,T1,60,30,0\n")
    result = run("replay", "a.csv", "b.csv", "--together", "--scene", "scene.toml", "--poses", "p.csv")
    assert result.exit_code == 3 and "entity 'T1' is also in" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not (flat / "p.csv").exists()
    # one entity with one row: a vehicle standing still, valid
    (flat / "c.csv").write_text("t,entity,x,y,yaw_deg\n0,T2,60,30,0\n")
    assert run("replay", "a.csv", "c.csv", "--together", "--scene", "scene.toml", "--poses", "p.csv").exit_code == 0


def test_the_drums_are_each_vehicles_own(run, flat):
    # the [vehicle] is an M1 (no drums); T is a T-72 with its drums by its [[entity]] table: both turn the
    # gun low over the rear deck, and only T's gun meets drums; the summary says the check ran
    (flat / "scene.toml").write_text('[terrain]\npath = "flat.asc"\n\n[vehicle]\npreset = "m1"\n\n'
                                     '[[entity]]\nid = "T"\npreset = "t72"\n')
    (flat / "ex.csv").write_text("t,entity,x,y,yaw_deg,turret_deg,gun_deg\n" + "".join(
        f"{k},T,40,30,0,{170 + 2 * k},-5\n{k},M,100,30,0,{170 + 2 * k},-5\n" for k in range(5)))
    events, summary = _replay(run, flat)
    internal = [e for e in events if e["kind"] == "internal"]
    assert {e["entity"] for e in internal} == {"T"} and len(internal) == 5
    assert summary["effects"]["internal"] is True


def test_rows_out_of_time_order_across_vehicles_are_said_not_lost_silently(flat):
    """An exercise whose rows come one vehicle after the other (each in its own time order, valid
    rows) cannot have its contacts between vehicles checked once the first vehicle's windows have
    closed: a set-up warning names the vehicle and the row. In time order the same rows give the
    head-on contact and no warning."""
    import warnings

    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning
    from tankcd_cli.replay.records import ReplayOptions
    from tankcd_cli.replay.run import replay_rows

    rows = []
    for k in range(41):
        t = 0.25 * k
        rows += [(t, "A", 10 + 8 * t, 30, 0), (t, "B", 150 - 7 * t, 30, 180)]
    world = api.load_world(scene=str(flat / "scene.toml"))
    options = ReplayOptions(chunk_rows=10)
    for name, ordered in (("timed.csv", rows), ("grouped.csv", sorted(rows, key=lambda r: r[1]))):
        _write(flat / name, ordered)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            _, events = replay_rows(world, str(flat / name), options)
        said = [str(w.message) for w in caught if issubclass(w.category, SetupWarning)]
        late = [m for m in said if "not in time order across vehicles" in m]
        if name == "timed.csv":
            assert [e["kind"] for e in events].count("vehicle") == 1 and not late
        else:
            assert len(late) == 1 and "entity 'B'" in late[0] and "row 41" in late[0]
