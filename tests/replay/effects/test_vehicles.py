"""Many vehicles in one world: contacts between vehicles against closed forms and a brute-force
oracle; one entity as a lone replay; entities appearing late; windows and chunks cutting contacts."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

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

    sample = Path(__file__).resolve().parents[3] / "sample_data"
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
    from tankcd_cli.replay.effects import vehicles as engine
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


def _replay_rows(world, trajectory, chunk_rows):
    from tankcd_cli import api
    from tankcd_cli.replay.records import ReplayOptions
    from tankcd_cli.replay.run import replay_rows

    if isinstance(trajectory, dict):  # columns: their chunks in a list (read twice, as a file is)
        trajectory = list(api.trajectory_chunks(trajectory, chunk_rows=chunk_rows))
    return replay_rows(world, trajectory, ReplayOptions(chunk_rows=chunk_rows))


STEPS = ("step", "a_step", "b_step")


def _events_but_steps(events):
    """The events as comparable text, without the step numbers (which count each file's own rows)."""
    return sorted(json.dumps({k: v for k, v in e.items() if k not in STEPS}, sort_keys=True) for e in events)


def _poses_by_row(poses):
    """Each pose row keyed by (entity, t), its columns but the step, in the input's row order."""
    keys = [k for k in poses if k != "step"]
    return [((poses["entity"][i], float(poses["t"][i])),
             tuple(poses[k][i] if not isinstance(poses[k][i], float) or poses[k][i] == poses[k][i] else "nan"
                   for k in keys)) for i in range(len(poses["t"]))]


def _same_as_in_time_order(world, timed, other, chunk_rows, write=None):
    """``other`` (the rows of ``timed`` in another order) gives the events of ``timed`` (but the steps)
    and, row for row in its own order, the same poses; returns the events."""
    p1, e1 = _replay_rows(world, timed if write is None else write("timed.csv", timed), chunk_rows)
    p2, e2 = _replay_rows(world, other if write is None else write("other.csv", other), chunk_rows)
    assert _events_but_steps(e2) == _events_but_steps(e1)
    by_row = dict(_poses_by_row(p1))
    got = _poses_by_row(p2)
    assert len(got) == len(by_row) and [row for _, row in got] == [by_row[key] for key, _ in got]
    return e1


@pytest.mark.parametrize("chunk_rows", [7, 50])
def test_rows_grouped_by_vehicle_give_the_events_and_poses_of_the_rows_in_time_order(flat, chunk_rows):
    """An exercise whose rows come one vehicle after the other (``sort -k entity``), across many
    chunks: the same contacts (every field but the steps) as the same rows in time order, the same
    poses row for row (in each file's own order), and no warning."""
    import warnings

    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning

    world = api.load_world(scene=str(flat / "scene.toml"))
    timed = _exercise(np.random.default_rng(5), 6, area=15.0, seconds=8.0)
    grouped = sorted(timed, key=lambda r: r[1])

    def write(name, rows):
        _write(flat / name, rows)
        return str(flat / name)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        events = _same_as_in_time_order(world, timed, grouped, chunk_rows, write)
    assert sum(e["kind"] == "vehicle" for e in events) >= 3
    assert not [w for w in caught if issubclass(w.category, SetupWarning)]


def test_the_head_on_contact_of_rows_grouped_by_vehicle(flat):
    """The rows of the head-on closed form one vehicle after the other, in chunks of 10: the one
    contact, at the time of the rows in time order (where the old streaming checks lost it)."""
    from tankcd_cli import api

    rows = []
    for k in range(41):
        t = 0.25 * k
        rows += [(t, "A", 10 + 8 * t, 30, 0), (t, "B", 150 - 7 * t, 30, 180)]
    world = api.load_world(scene=str(flat / "scene.toml"))
    _write(flat / "grouped.csv", sorted(rows, key=lambda r: r[1]))
    _, events = _replay_rows(world, str(flat / "grouped.csv"), 10)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    assert len(vehicle) == 1 and vehicle[0]["t"] == pytest.approx((150 - 10 - 2 * 6.1) / 15, abs=1e-3)
    k = int(vehicle[0]["t"] // 0.25)  # the interval's earlier row: A's rows are lines 0..40, B's 41..81
    assert vehicle[0]["a_step"] == k and vehicle[0]["b_step"] == 41 + k


def _columns(rows):
    return {"t": [r[0] for r in rows], "entity": [r[1] for r in rows], "x": [r[2] for r in rows],
            "y": [r[3] for r in rows], "yaw_deg": [r[4] for r in rows]}


def test_api_replay_of_a_shuffled_entity_array_is_the_time_ordered_one(flat, monkeypatch):
    """api.replay with the rows of an exercise shuffled (each vehicle's own rows still in order) or
    grouped by vehicle, in chunks of 9 rows: the events and poses of the rows in time order."""
    import functools

    from tankcd_cli import api
    from tankcd_cli.replay.effects import vehicles

    monkeypatch.setattr(api, "trajectory_chunks", functools.partial(api.trajectory_chunks, chunk_rows=9))
    modes = []
    init = vehicles.VehicleContacts.__init__

    def remember(self, *args, **kwargs):
        init(self, *args, **kwargs)
        modes.append(self.spill is None)

    monkeypatch.setattr(vehicles.VehicleContacts, "__init__", remember)

    world = api.load_world(scene=str(flat / "scene.toml"))
    timed = _exercise(np.random.default_rng(7), 5, area=14.0)
    rng = np.random.default_rng(1)
    # a random interleaving that keeps each vehicle's order: shuffle, then give each vehicle its rows back in order
    who = np.array([r[1] for r in timed])
    slots = rng.permutation(len(timed))
    mixed = [None] * len(timed)
    for name in np.unique(who):
        mine = [r for r in timed if r[1] == name]
        places = np.sort(slots[who == name])
        for place, r in zip(places, mine):
            mixed[place] = r
    p1, e1 = api.replay(_columns(timed), world=world)
    assert any(e["kind"] == "vehicle" for e in e1)
    by_row = dict(_poses_by_row(p1))
    for rows in (mixed, sorted(timed, key=lambda r: r[1])):
        p2, e2 = api.replay(_columns(rows), world=world)
        assert _events_but_steps(e2) == _events_but_steps(e1)
        assert [row for _, row in _poses_by_row(p2)] == [by_row[key] for key, _ in _poses_by_row(p2)]
    # in time order, and shuffled (every vehicle still sending: the watermark waits for each), the checks
    # stream; grouped by vehicle, the segments are spilled
    assert modes[0] and not modes[2]


def test_files_together_each_grouped_by_vehicle(run, flat):
    """--together of two files, each of several vehicles grouped by vehicle: the events of one file
    of all the rows in time order."""
    rows = _exercise(np.random.default_rng(2), 6, area=18.0)
    _write(flat / "ex.csv", rows)
    one, _ = _replay(run, flat)
    names = sorted({r[1] for r in rows})
    for part, mine in (("a", names[:3]), ("b", names[3:])):
        _write(flat / f"{part}.csv", sorted((r for r in rows if r[1] in mine), key=lambda r: r[1]))
    result = run("replay", "a.csv", "b.csv", "--together", "--scene", "scene.toml", "--poses", "q.csv",
                 "--events", "f.jsonl")
    assert result.exit_code == 0, result.stderr
    together = [json.loads(line) for line in (flat / "f.jsonl").read_text().splitlines()]
    assert any(e["kind"] == "vehicle" for e in one)
    assert _events_but_steps(together) == _events_but_steps(one)


def test_a_vehicle_silent_past_the_horizon_is_checked_all_the_same(flat):
    """B stands silent from t = 0 to t = 100 (past the 30 s horizon), where A, driving at 1 m/s, runs
    its gun into B's rear at t = 62.5: the contact is found, in time order or grouped, with no
    warning."""
    import warnings

    from tankcd_cli import api
    from tankcd_cli.errors import SetupWarning

    world = api.load_world(scene=str(flat / "scene.toml"))
    rows = [(float(t), "A", 10 + t, 30, 0) for t in range(0, 101, 2)]
    rows += [(0.0, "B", 70 + 6.1 + 3.43 + 0.5, 30, 0), (100.0, "B", 70 + 6.1 + 3.43 + 0.5, 30, 0)]
    timed = sorted(rows)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        events = _same_as_in_time_order(world, _columns(timed), _columns(sorted(rows, key=lambda r: r[1])), 8)
    vehicle = [e for e in events if e["kind"] == "vehicle"]
    assert len(vehicle) == 1 and 60 < vehicle[0]["t"] < 65 and vehicle[0]["a_part"] == "gun"
    assert not [w for w in caught if issubclass(w.category, SetupWarning)]


@settings(max_examples=6, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([5, 16, 1000]))
@example(106064, 5)  # v2's first row comes after the windows up to 2 s closed: it must spill, not stream
def test_any_interleaving_gives_the_events_of_time_order(seed, chunk_rows):
    """A random interleaving of an exercise's rows that keeps each vehicle's own order, in random
    chunks: the events and poses of the rows in time order."""
    world = _hypothesis_world()
    rng = np.random.default_rng(seed)
    timed = _exercise(np.random.default_rng(11), 4, area=12.0, seconds=4.0)
    by = {}
    for r in timed:
        by.setdefault(r[1], []).append(r)
    queues = {k: list(v) for k, v in by.items()}
    mixed = []
    while queues:
        k = sorted(queues)[int(rng.integers(len(queues)))]
        mixed.append(queues[k].pop(0))
        if not queues[k]:
            del queues[k]
    _same_as_in_time_order(world, _columns(timed), _columns(mixed), chunk_rows)


_WORLD = {}


def _hypothesis_world():
    """One flat world for the property test's examples (hypothesis gives no function fixture)."""
    import tempfile
    from pathlib import Path

    from tankcd_cli import api

    if "w" not in _WORLD:
        folder = Path(tempfile.mkdtemp(prefix="tankcd-test-order-"))
        write_asc(folder / "flat.asc", np.full((80, 160), GROUND))
        (folder / "scene.toml").write_text('[terrain]\npath = "flat.asc"\n\n[vehicle]\npreset = "t72"\n'
                                           'fuel_drums = false\n')
        _WORLD["w"] = api.load_world(scene=str(folder / "scene.toml"))
    return _WORLD["w"]


def test_a_billion_seconds_of_empty_time_cost_nothing_and_hide_no_contact(flat):
    """Two vehicles, and one more row of each a billion seconds later, where they meet head on: the
    windows skip the empty time (one pass per 2 s window would never finish) and the contact after
    the gap is found where the closed form puts it."""
    import time

    from tankcd_cli import api

    world = api.load_world(scene=str(flat / "scene.toml"))
    late = 1e9
    rows = [(0.0, "A", 20, 30, 0), (1.0, "A", 21, 30, 0), (0.0, "B", 120, 30, 180), (1.0, "B", 119, 30, 180)]
    for k in range(21):
        t = late + 0.5 * k
        rows += [(t, "A", 10 + 8 * (t - late), 30, 0), (t, "B", 150 - 7 * (t - late), 30, 180)]
    for order, chunk_rows in ((sorted(rows), 65536), (sorted(rows), 7), (sorted(rows, key=lambda r: r[1]), 7)):
        start = time.perf_counter()
        poses, events = _replay_rows(world, _columns(order), chunk_rows)  # streamed, streamed, spilled
        seconds = time.perf_counter() - start
        vehicle = [e for e in events if e["kind"] == "vehicle"]
        assert len(vehicle) == 1 and vehicle[0]["a"] == "A" and vehicle[0]["a_part"] == "gun"
        assert vehicle[0]["t"] - late == pytest.approx((150 - 10 - 2 * 6.1) / 15, abs=1e-3)
        assert seconds < 5  # a few hundred milliseconds; a pass per window: 5e8 of them


def test_a_vehicle_contact_between_rows_says_so_and_one_at_a_first_row_does_not(flat):
    """A contact the sweep finds along the motion carries "between": true (as every other kind); one
    present where a vehicle begins to exist is at that row and carries none."""
    from tankcd_cli import api

    world = api.load_world(scene=str(flat / "scene.toml"))
    rows = []
    for k in range(21):
        t = 0.5 * k
        rows += [(t, "A", 10 + 8 * t, 30, 0), (t, "B", 150 - 7 * t, 30, 180)]
    rows += [(3.0, "C", 34 + 3, 30, 90), (4.0, "C", 34 + 3, 30, 90)]  # appears in A's hull at t = 3
    _, events = api.replay(_columns(sorted(rows)), world=world)
    vehicle = {(e["a"], e["b"]): e for e in events if e["kind"] == "vehicle"}
    assert vehicle[("A", "B")]["between"] is True
    assert vehicle[("A", "C")]["t"] == 3.0 and "between" not in vehicle[("A", "C")]


def test_a_quiet_summary_carries_the_warnings_of_a_grouped_exercise(run, flat):
    """-q --summary - on an exercise grouped by vehicle that warns (a step no vehicle makes): the
    summary JSON's warnings list names it, and a world warning said while loading is there too."""
    rows = [(float(t), "A", 10 + 2 * t, 30, 0) for t in range(6)] + [(6.0, "A", 120, 30, 0)]
    rows += [(float(t), "B", 60, 50 - 2 * t, 270) for t in range(7)]
    _write(flat / "ex.csv", sorted(rows, key=lambda r: r[1]))
    from tests.conftest import write_obj

    box = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    faces = [[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4], [2, 6, 3], [3, 6, 7], [0, 4, 2],
             [2, 4, 6], [1, 3, 5], [3, 7, 5]]
    write_obj(flat / "crate.obj", box, faces)
    (flat / "scene.toml").write_text((flat / "scene.toml").read_text() + '\n[[obstacle]]\nname = "crate"\n'
                                     'path = "crate.obj"\nposition = [5000.0, 10.0, 0.0]\n')  # off the terrain
    result = run("-q", "replay", "ex.csv", "--scene", "scene.toml", "--poses", "p.csv", "--summary", "-")
    assert result.exit_code == 0, result.stderr
    assert result.stderr == ""  # -q: nothing said
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert any("entity 'A'" in w and "faster than any vehicle" in w for w in summary["warnings"])
    assert any("obstacle 'crate' lies off the terrain" in w for w in summary["warnings"])


def test_the_spill_is_removed_at_the_end_and_when_the_replay_fails(flat, monkeypatch):
    """The spilled segments live in an unnamed temporary file: closed (gone) when the replay ends, and
    when a bad row stops it half way."""
    from tankcd_cli import api
    from tankcd_cli.errors import InputError
    from tankcd_cli.replay.effects import vehicles

    made = []
    init = vehicles.SegmentSpill.__init__

    def remember(self, window):
        init(self, window)
        made.append(self)

    monkeypatch.setattr(vehicles.SegmentSpill, "__init__", remember)
    world = api.load_world(scene=str(flat / "scene.toml"))
    rows = sorted(_exercise(np.random.default_rng(5), 4, area=15.0), key=lambda r: r[1])
    _write(flat / "grouped.csv", rows)
    _replay_rows(world, str(flat / "grouped.csv"), 7)
    assert len(made) == 1 and made[0].records > 0 and made[0].file.closed
    (flat / "bad.csv").write_text((flat / "grouped.csv").read_text() + "9.5,v0,nan,30,0\n")
    with pytest.raises(InputError, match="line"):
        _replay_rows(world, str(flat / "bad.csv"), 7)
    assert len(made) == 2 and made[1].records > 0 and made[1].file.closed


def test_a_fleet_of_an_exercise_grouped_and_in_time_order(flat, tmp_path):
    """A fleet of two exercises, the same rows in time order and grouped by vehicle, in chunks of 7
    rows: each its own task, the same events."""
    from tankcd_cli.replay.executor import TaskWorld
    from tankcd_cli.replay.fleet import plan_tasks, run_fleet
    from tankcd_cli.replay.records import ReplayOptions
    from tankcd_cli.replay.world import WorldSpec

    rows = _exercise(np.random.default_rng(5), 5, area=15.0)
    (flat / "a").mkdir()
    (flat / "b").mkdir()
    _write(flat / "a" / "timed.csv", rows)
    _write(flat / "b" / "grouped.csv", sorted(rows, key=lambda r: r[1]))
    world = TaskWorld(WorldSpec(scene=str(flat / "scene.toml")), ReplayOptions(chunk_rows=7))
    out = tmp_path / "out"
    out.mkdir()
    tasks = plan_tasks([str(flat / "a" / "timed.csv"), str(flat / "b" / "grouped.csv")], str(out))
    fleet = run_fleet(world, tasks)
    assert fleet.ok == 2, fleet
    timed, grouped = ([json.loads(line) for line in open(t.events)] for t in tasks)
    assert any(e["kind"] == "vehicle" for e in timed)
    assert _events_but_steps(grouped) == _events_but_steps(timed)


def _platoons(rng, platoons=3, seconds=8.0, hz=4.0):
    """Platoons of four T-72s 12 m abreast, each its own heading and speed, steered into the middle
    of the flat ground so that platoons cross: pairs far apart, pairs side by side, pairs that meet."""
    rows = []
    for p in range(platoons):
        heading = rng.uniform(-180, 180)
        speed = rng.uniform(2, 7)
        h = np.radians(heading)
        # start so the platoon's path crosses the middle half-way through
        cx = 80 - np.cos(h) * speed * seconds / 2 + rng.uniform(-8, 8)
        cy = 40 - np.sin(h) * speed * seconds / 2 + rng.uniform(-8, 8)
        phase = rng.uniform(0, 1 / hz)
        for v in range(4):
            off = (v - 1.5) * 12.0
            for k in range(int(seconds * hz)):
                t = phase + k / hz
                x = cx - np.sin(h) * off + np.cos(h) * speed * t
                y = cy + np.cos(h) * off + np.sin(h) * speed * t
                rows.append((round(t, 3), f"p{p}v{v}", round(x, 3), round(y, 3), round(heading, 3)))
    return sorted(rows)


@pytest.mark.parametrize("seed", [3, 8, 21])
def test_the_pair_gate_changes_no_pose_and_no_event(flat, tmp_path, seed):
    """Random exercises (platoons crossing, vehicles wandering), in time order and grouped by vehicle
    (spilled), in one piece and by windows: with the gates on and off (``gates=False``: every pair
    the broad phase gives takes the narrow phase), the poses and events byte for byte; the summary
    counts the gate's pair-windows, some proven clear and some not."""
    from tankcd_cli import api

    rng = np.random.default_rng(seed)
    rows = _platoons(rng) + [(t, "w" + e, x, y, yaw) for t, e, x, y, yaw in _exercise(rng, 5, area=30.0, hz=4.0)]
    world = api.load_world(scene=str(flat / "scene.toml"))
    for order, got in (("time", sorted(rows)), ("grouped", sorted(rows, key=lambda r: (r[1], r[0])))):
        _write(flat / f"{order}.csv", got)
        out = {}
        for gates in (True, False):
            d = tmp_path / f"{order}-{gates}"
            d.mkdir()
            s = api.replay_to_files(str(flat / f"{order}.csv"), str(d / "p.csv"), str(d / "e.jsonl"), world=world,
                                    gates=gates)
            w = api.replay_windows(str(flat / f"{order}.csv"), str(d / "wp.csv"), str(d / "we.jsonl"),
                                   world=world, window_seconds=3.0, gates=gates)
            out[gates] = d, s, w
            if gates:
                for summary in (s, w):
                    pairs = summary.gates["vehicle_pairs"]
                    assert 0 < pairs["skipped"] < pairs["checked"], pairs
                assert s.gates["vehicle_pairs"] == w.gates["vehicle_pairs"]
            else:
                assert "vehicle_pairs" not in s.gates and "vehicle_pairs" not in w.gates
        (on, s_on, _), (off, s_off, _) = out[True], out[False]
        assert s_on.vehicle_contacts == s_off.vehicle_contacts > 0
        for name in ("p.csv", "e.jsonl", "wp.csv", "we.jsonl"):
            assert (on / name).read_bytes() == (off / name).read_bytes(), f"{order}: {name}"
        assert (on / "e.jsonl").read_bytes() == (on / "we.jsonl").read_bytes()


def test_the_pair_gate_changes_no_contact_of_turrets_swinging_between_platoons(flat, tmp_path):
    """Platoons abreast whose turrets swing fast (up to 90 deg/s) and guns rise and fall, the guns
    sweeping over the neighbours' hulls: the turn and articulation bounds at work; the gates on and off
    give the same poses and events byte for byte."""
    from tankcd_cli import api

    rng = np.random.default_rng(5)
    rows = _platoons(rng, platoons=2, seconds=6.0)
    swing = {e: (rng.uniform(-90, 90), rng.uniform(-180, 180)) for e in {r[1] for r in rows}}
    lines = ["t,entity,x,y,yaw_deg,turret_deg,gun_deg"]
    for t, e, x, y, yaw in rows:
        rate, start = swing[e]
        lines.append(f"{t},{e},{x},{y},{yaw},{round(start + rate * t, 3)},{round(5 + 5 * np.sin(t), 3)}")
    # and two standing 12 m abreast, guns forward at first, turning towards each other at 45 deg/s: the
    # guns (6.45 m from the turret axis) meet across the 12 m; at the window's start nothing is near
    for k in range(25):
        t = 0.25 * k
        lines += [f"{t},s0,80,20,0,{45 * t},0", f"{t},s1,80,32,0,{-45 * t},0"]
    lines[1:] = sorted(lines[1:], key=lambda line: float(line.split(",")[0]))
    (flat / "swing.csv").write_text("\n".join(lines) + "\n")
    world = api.load_world(scene=str(flat / "scene.toml"))
    out = {}
    for gates in (True, False):
        d = tmp_path / str(gates)
        d.mkdir()
        out[gates] = d, api.replay_to_files(str(flat / "swing.csv"), str(d / "p.csv"), str(d / "e.jsonl"),
                                            world=world, gates=gates)
    (on, s_on), (off, s_off) = out[True], out[False]
    assert s_on.gates["vehicle_pairs"]["skipped"] > 0 and s_on.vehicle_contacts == s_off.vehicle_contacts
    events = [json.loads(line) for line in (on / "e.jsonl").read_text().splitlines()]
    assert [(e["a_part"], e["b_part"]) for e in events if (e["kind"], e["a"], e["b"]) == ("vehicle", "s0", "s1")] == [
        ("gun", "gun")]
    assert (on / "p.csv").read_bytes() == (off / "p.csv").read_bytes()
    assert (on / "e.jsonl").read_bytes() == (off / "e.jsonl").read_bytes()


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["t72", "m1", "t55"]))
@example(3, "t72")
def test_a_segments_broad_phase_box_holds_every_point_of_its_vehicle_throughout(seed, name):
    """Random rigid segments (travel, turns with roll and pitch, the turret and gun swinging): every
    vertex of the body's triangles, placed at 41 fractions of each segment, lies in the box the broad
    phase gives it (the sweep of its groups' spheres)."""
    from tankcd_cli.bvh.sweep import chain_placements
    from tankcd_cli.collision.pair_gate import group_spheres
    from tankcd_cli.collision.vehicle_body import vehicle_body
    from tankcd_cli.collision.vehicles import SpanMotion
    from tankcd_cli.geometry.pose import quaternion_from_euler
    from tankcd_cli.replay.effects.vehicles import _sphere_boxes
    from tankcd_cli.vehicle import vehicle_preset
    from tankcd_cli.vehicle_mesh import PARTS, vehicle_mesh

    rng = np.random.default_rng(seed)
    preset = vehicle_preset(name)
    body = vehicle_body(preset, *vehicle_mesh(preset, 2), PARTS)
    n = 24
    c0 = rng.uniform(-1e3, 1e3, (n, 3)) + [500000.0, 4500000.0, 0.0]
    c1 = c0 + rng.normal(0, 3, (n, 3)) * [1, 1, 0.1]
    yaw0 = rng.uniform(-np.pi, np.pi, n)
    tilt = rng.uniform(-0.2, 0.2, (n, 4))
    q0 = quaternion_from_euler(tilt[:, 0], tilt[:, 1], yaw0)
    q1 = quaternion_from_euler(tilt[:, 2], tilt[:, 3], yaw0 + rng.uniform(-0.7, 0.7, n))
    turret0, dturret = rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi, np.pi, n)
    gun0, dgun = rng.uniform(-0.1, 0.3, n), rng.uniform(-0.3, 0.3, n)
    spheres = group_spheres(body, q0, c0, q1, turret0, dturret, gun0, dgun)
    lo, hi = _sphere_boxes(spheres, c0, c1)
    motion = SpanMotion(q0, c0, q1, c1, turret0, dturret, gun0, dgun)
    for s in np.linspace(0.0, 1.0, 41):
        for g in body.groups:
            rows, joints = motion.rows(body, g)
            R, t = chain_placements(rows, joints, np.full(n, s))
            points = np.einsum("nij,mj->nmi", R, g.tree.triangles.reshape(-1, 3)) + t[:, None, :]
            assert (points >= lo[:, None, :] - 1e-9).all() and (points <= hi[:, None, :] + 1e-9).all()
    # and tighter than the body's radius about the origin, sideways, wherever the gun points ahead
    ahead = group_spheres(body, q0, c0, q0, np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))
    lo, hi = _sphere_boxes(ahead, c0, c0)
    assert (hi - lo)[:, :2].min(axis=1).max() < 2 * body.radius


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31 - 1), window=st.sampled_from([2.0, 0.7, 3.0, 1.9]),
       ends=st.lists(st.floats(0.05, 3.0), min_size=1, max_size=12))
def test_a_window_reads_exactly_the_segments_the_rule_says_and_keeps_the_rest(monkeypatch, seed, window, ends):
    """Each window's segments are those with t0 < w1 (t0 <= w1 at the last) and t1 >= w0 among the ones
    added and not yet left behind (t1 < an earlier w1), whatever the chunks' order inside and wherever
    w1 falls against the buffer's buckets (on their grid or off it, with starts on a window's edge).
    The patches are the same for every example (they only record), so the shared fixture is safe."""
    from tankcd_cli.replay.between_rows import Segments
    from tankcd_cli.replay.effects import vehicles

    rng = np.random.default_rng(seed)
    seen = []

    def boxes(spheres, c0, c1):  # the window's segments, by the id carried in c0
        seen.append(np.sort(c0[:, 0].astype(np.int64)))
        return np.zeros((len(c0), 3)), np.zeros((len(c0), 3))

    monkeypatch.setattr(vehicles, "_sphere_boxes", boxes)
    monkeypatch.setattr(vehicles, "candidate_pairs", lambda *a, **k: np.zeros((0, 2), np.int64))
    monkeypatch.setattr(vehicles.VehicleContacts, "_spheres", lambda self, s, k: None)

    class Kind:
        index = 0

    contacts = vehicles.VehicleContacts(None, window=window)
    n, total = 0, []
    cuts = np.cumsum(ends)
    for _ in range(4):  # chunks, each in no time order, some starts on the window grid
        m = int(rng.integers(1, 60))
        t0 = rng.uniform(0, cuts[-1] + 1, m)
        on_grid = rng.random(m) < 0.2
        t0[on_grid] = window * rng.integers(0, int(cuts[-1] / window) + 2, on_grid.sum())
        t1 = t0 + rng.choice([0.0, 0.1, 0.5, 2.5], m)
        ids = np.arange(n, n + m)
        z = np.zeros(m)
        segs = Segments(np.zeros(m, np.int64), ids, t0, t1, np.zeros((m, 4)), np.column_stack([ids, z, z]),
                        np.zeros((m, 4)), np.zeros((m, 3)), z, z, z, z, np.zeros(m, bool))
        contacts.add(Kind, segs.take(rng.permutation(m)))
        total.append((ids, t0, t1))
        n += m
    ids = np.concatenate([t[0] for t in total])
    t0 = np.concatenate([t[1] for t in total])
    t1 = np.concatenate([t[2] for t in total])
    alive = np.ones(n, dtype=bool)
    w0 = 0.0
    for i, w1 in enumerate(cuts):
        last = i == len(cuts) - 1
        seen.clear()
        contacts.close_window(w0, w1, last)
        want = np.flatnonzero(alive & (t1 >= w0) & ((t0 < w1) | (last & (t0 <= w1))))
        got = seen[0] if seen else np.zeros(0, np.int64)
        if len(want) >= 2:
            assert got.tolist() == np.sort(ids[want]).tolist()
        else:
            assert len(got) == 0
        alive &= t1 >= w1
        buffered = np.sort(np.concatenate([p.c0[:, 0] for _, p, _ in contacts.buffer]).astype(np.int64)) \
            if contacts.buffer else np.zeros(0, np.int64)
        assert buffered.tolist() == np.sort(ids[alive]).tolist()
        w0 = w1
