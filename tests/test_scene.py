"""The scene schema: required positions, scale and full rotations of obstacles and of the
vehicle mesh, vehicle parts from the mesh file, and info checking a scene as replay reads it."""

import json
import re

import numpy as np
import pytest

from tankcd_cli.io.terrain_readers import RawTerrain
from tankcd_cli.vehicle_mesh import box
from tests.conftest import write_asc

X0, Y0 = 500000.0, 4500000.0
PARTS_LANDED = hasattr(RawTerrain, "face_part") or "face_part" in getattr(RawTerrain, "__dataclass_fields__", {})


def write_tris(path, tris, objects=None):
    """An OBJ of triangles (m, 3, 3); ``objects``: [(name, count)] split them into `o` objects in order."""
    tris = np.asarray(tris, dtype=float)
    with open(path, "w") as fh:
        for tri in tris:
            for v in tri:
                fh.write("v %r %r %r\n" % tuple(float(c) for c in v))
        spans = objects or [(None, len(tris))]
        i = 0
        for name, count in spans:
            if name:
                fh.write(f"o {name}\n")
            for _ in range(count):
                fh.write(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n")
                i += 1
    return path


def rot(roll_deg, pitch_deg, yaw_deg):
    """Rz(yaw) Ry(pitch) Rx(roll), written out here independently of the project's code."""
    r, p, y = np.radians([roll_deg, pitch_deg, yaw_deg])
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def corners(lo, hi):
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], dtype=float)


def walk_keys(value, path="$"):
    """Every (path, key) of every object in a JSON value, and every string value."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield "key", f"{path}.{k}", k
            yield from walk_keys(v, f"{path}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from walk_keys(v, f"{path}[{i}]")
    elif isinstance(value, str):
        yield "string", path, value


@pytest.fixture
def block(tmp_path):
    write_tris(tmp_path / "block.obj", box([-1, -2, 0], [1, 2, 3]))
    return tmp_path / "block.obj"


def test_an_obstacle_without_a_position_is_refused_naming_the_key(run, block):
    (block.parent / "scene.toml").write_text('[[obstacle]]\nname = "block"\npath = "block.obj"\n')
    for command in (["info", "scene.toml"], ["collide", "--scene", "scene.toml", "--poses", "poses.csv"]):
        (block.parent / "poses.csv").write_text("x,y,z,roll_deg,pitch_deg,yaw_deg\n0,0,0,0,0,0\n")
        result = run(*command)
        assert result.exit_code == 3, result.output
        assert "[[obstacle]] 1 position" in result.stderr and "scene.toml" in result.stderr


@pytest.mark.parametrize("text,fragment", [
    ("scale = 0", "[[obstacle]] 1 scale"),
    ("scale = -1.0", "[[obstacle]] 1 scale"),
    ("scale = [1.0, 2.0]", "[[obstacle]] 1 scale"),
    ('scale = "mm"', "[[obstacle]] 1 scale"),
    ("scale = nan", "[[obstacle]] 1 scale"),
    ("scale = [1.0, inf, 1.0]", "[[obstacle]] 1 scale"),
    ("pitch_deg = nan", "[[obstacle]] 1 pitch_deg"),
    ('roll_deg = "5"', "[[obstacle]] 1 roll_deg"),
    ('up = "x"', "[[obstacle]] 1 up"),
])
def test_bad_placements_are_refused_naming_the_key(run, block, text, fragment):
    (block.parent / "scene.toml").write_text(
        f'[[obstacle]]\nname = "block"\npath = "block.obj"\nposition = [0.0, 0.0, 0.0]\n{text}\n')
    result = run("info", "scene.toml")
    assert result.exit_code == 3
    assert fragment in result.stderr, result.stderr


def test_vehicle_mesh_keys_without_a_mesh_are_refused(run, tmp_path):
    (tmp_path / "scene.toml").write_text("[vehicle]\nmesh_scale = 0.001\n")
    result = run("info", "scene.toml")
    assert result.exit_code == 3 and "[vehicle] mesh_scale" in result.stderr


@pytest.mark.parametrize("placement", [
    {"scale": 0.5},
    {"scale": [0.001, 2.0, 3.0]},
    {"yaw_deg": 30.0},
    {"yaw_deg": 30.0, "pitch_deg": 20.0, "roll_deg": -50.0},
    {"yaw_deg": -120.0, "pitch_deg": 75.0, "roll_deg": 10.0, "scale": [2.0, 0.5, 1.5]},
])
def test_scale_and_rotation_place_the_obstacle_where_an_independent_computation_does(run, block, placement):
    position = [X0 + 12.5, Y0 - 3.25, 101.0]
    keys = "".join(f"{k} = {json.dumps(v)}\n" for k, v in placement.items())
    (block.parent / "scene.toml").write_text(
        f'[[obstacle]]\nname = "block"\npath = "block.obj"\nposition = {json.dumps(position)}\n{keys}')
    result = run("info", "scene.toml", "--json")
    assert result.exit_code == 0, result.stderr
    ob = json.loads(result.stdout)["obstacles"][0]
    scale = placement.get("scale", 1.0)
    scale = np.array(scale if isinstance(scale, list) else [scale] * 3)
    R = rot(placement.get("roll_deg", 0.0), placement.get("pitch_deg", 0.0), placement.get("yaw_deg", 0.0))
    world = (corners([-1, -2, 0], [1, 2, 3]) * scale) @ R.T + position
    np.testing.assert_allclose(ob["bounds"]["min"], world.min(axis=0), atol=1e-9)
    np.testing.assert_allclose(ob["bounds"]["max"], world.max(axis=0), atol=1e-9)
    assert ob["triangles"] == 12 and ob["position"] == position
    np.testing.assert_allclose(ob["scale"], scale)
    for key in ("yaw_deg", "pitch_deg", "roll_deg"):
        assert ob[key] == placement.get(key, 0.0)
    text = run("info", "scene.toml").stdout
    assert "block:" in text and "bounds:" in text and "scale:" in text


def _collide_scene(tmp_path, obstacle_keys):
    (tmp_path / "scene.toml").write_text(
        '[vehicle]\npreset = "t72"\n\n[[obstacle]]\nname = "block"\npath = "block.obj"\n'
        f'position = [{X0 + 10}, {Y0}, 0.0]\nyaw_deg = 45\n{obstacle_keys}')
    rows = ["step,t,x,y,z,roll_deg,pitch_deg,yaw_deg"]
    for k, x in enumerate([X0, X0 + 6.0, X0 + 20.0, X0 + 10.0]):
        rows.append(f"{k},{k * 0.5},{x},{Y0},0,0,0,0")
    (tmp_path / "poses.csv").write_text("\n".join(rows) + "\n")


def test_an_asset_in_millimetres_scaled_collides_where_the_same_asset_in_metres_does(run, tmp_path):
    write_tris(tmp_path / "block.obj", box([-1, -1, 0], [1, 1, 3]))
    _collide_scene(tmp_path, "")
    metres = run("collide", "--scene", "scene.toml", "--poses", "poses.csv")
    assert metres.exit_code == 0, metres.stderr
    hit_steps = [json.loads(line)["step"] for line in metres.stdout.splitlines()]
    assert sorted(set(hit_steps)) == [1, 3]  # an event per part in contact at those poses

    write_tris(tmp_path / "block.obj", box([-1000, -1000, 0], [1000, 1000, 3000]))  # the same block in mm
    _collide_scene(tmp_path, "scale = 0.001\n")
    mm = run("collide", "--scene", "scene.toml", "--poses", "poses.csv")
    assert mm.exit_code == 0, mm.stderr
    events = [json.loads(line) for line in mm.stdout.splitlines()]
    assert [e["step"] for e in events] == hit_steps and {e["b"] for e in events} == {"block"}
    for e in events:  # contact points on the block as placed: within its footprint, below its 3 m top
        x, y, z = e["point"]
        assert abs(x - (X0 + 10)) <= np.sqrt(2) + 1e-6 and abs(y - Y0) <= np.sqrt(2) + 1e-6 and 0 <= z <= 3 + 1e-6

    _collide_scene(tmp_path, "")  # unscaled, the 2 km block swallows every pose
    swallowed = run("collide", "--scene", "scene.toml", "--poses", "poses.csv").stdout.splitlines()
    assert len({json.loads(line)["step"] for line in swallowed}) == 4


def test_a_changed_scale_or_rotation_does_not_reuse_a_cached_tree(run, tmp_path):
    write_tris(tmp_path / "block.obj", box([-1, -1, 0], [1, 1, 3]))
    _collide_scene(tmp_path, "")
    assert run("bvh", "--scene", "scene.toml").exit_code == 0
    assert "cached" in run("-v", "bvh", "--scene", "scene.toml").stderr
    for keys in ("scale = 2.0\n", "scale = [2.0, 1.0, 1.0]\n", "pitch_deg = 5.0\n", "roll_deg = 5.0\n"):
        _collide_scene(tmp_path, keys)
        assert "stale" in run("-v", "bvh", "--scene", "scene.toml").stderr, keys


def test_vehicle_mesh_scale_and_rotation_bring_an_asset_into_the_vehicle_frame(run, tmp_path):
    # a 6 x 3 x 2 m hull modelled in mm with its length along y: turned -90 deg it points along x
    write_tris(tmp_path / "tank.obj", box([-1500, -3000, 0], [1500, 3000, 2000]))
    write_tris(tmp_path / "block.obj", box([-1, -1, 0], [1, 1, 3]))
    (tmp_path / "scene.toml").write_text(
        '[vehicle]\nmesh = "tank.obj"\nmesh_scale = 0.001\nmesh_yaw_deg = -90.0\n\n'
        f'[[obstacle]]\nname = "block"\npath = "block.obj"\nposition = [{X0 + 10}, {Y0}, 0.0]\n')
    facts = json.loads(run("info", "scene.toml", "--json").stdout)
    mesh = facts["vehicle"]["mesh"]
    np.testing.assert_allclose(mesh["bounds"]["min"], [-3, -1.5, 0], atol=1e-9)
    np.testing.assert_allclose(mesh["bounds"]["max"], [3, 1.5, 2], atol=1e-9)
    assert mesh["triangles"] == 12 and mesh["scale"] == [0.001] * 3 and mesh["yaw_deg"] == -90.0
    # the front (x = +3 m) reaches the block's face at x0 + 9 from x0 + 6.5, not from x0 + 7.5 (length along y)
    (tmp_path / "poses.csv").write_text("step,x,y,z,roll_deg,pitch_deg,yaw_deg\n"
                                        f"0,{X0 + 5.5},{Y0},0,0,0,0\n1,{X0 + 6.5},{Y0},0,0,0,0\n")
    events = [json.loads(line) for line in run("collide", "--scene", "scene.toml", "--poses", "poses.csv").stdout.splitlines()]
    assert [e["step"] for e in events] == [1] and events[0]["a"] == "vehicle"


@pytest.mark.skipif(not PARTS_LANDED, reason="RawTerrain has no face_part yet (OBJ objects as parts: the readers' change)")
def test_vehicle_parts_come_from_the_mesh_file(run, tmp_path):
    hull = box([-3, -1.5, 0.4], [3, 1.5, 2.0])
    turret = box([-1, -1, 2.0], [5, 1, 2.8])  # reaches 2 m past the hull's front, above it; not over its rear
    write_tris(tmp_path / "tank.obj", np.concatenate([hull, turret]), objects=[("hull", len(hull)), ("turret", len(turret))])
    write_tris(tmp_path / "post.obj", box([-0.2, -0.2, 0], [0.2, 0.2, 3]))
    (tmp_path / "scene.toml").write_text(
        '[vehicle]\nmesh = "tank.obj"\nmesh_up = "z"\n\n'
        f'[[obstacle]]\nname = "post"\npath = "post.obj"\nposition = [{X0 + 4}, {Y0}, 0.0]\n')
    (tmp_path / "poses.csv").write_text("step,x,y,z,roll_deg,pitch_deg,yaw_deg\n"
                                        f"0,{X0},{Y0},0,0,0,0\n1,{X0 + 6.5},{Y0},0,0,0,0\n")
    result = run("collide", "--scene", "scene.toml", "--poses", "poses.csv")
    assert result.exit_code == 0, result.stderr
    events = [json.loads(line) for line in result.stdout.splitlines()]
    assert [(e["step"], e["a"], e["b"]) for e in events] == [(0, "turret", "post"), (1, "hull", "post")]
    facts = json.loads(run("info", "scene.toml", "--json").stdout)
    assert facts["vehicle"]["mesh"]["parts"] == {"hull": 12, "turret": 12}


@pytest.mark.parametrize("name,content", [("sign.png", b"\x89PNG\r\n\x1a\n" + b"\0" * 64),
                                          ("house.dae", b"<?xml version='1.0'?><COLLADA></COLLADA>\n")])
def test_info_reads_every_obstacle_as_replay_does(run, tmp_path, name, content):
    (tmp_path / name).write_bytes(content)
    (tmp_path / "scene.toml").write_text(f'[[obstacle]]\nname = "x"\npath = "{name}"\nposition = [0.0, 0.0, 0.0]\n')
    result = run("info", "scene.toml")
    assert result.exit_code == 3
    assert name in result.stderr
    (tmp_path / "poses.csv").write_text("x,y,z,roll_deg,pitch_deg,yaw_deg\n0,0,0,0,0,0\n")
    assert run("collide", "--scene", "scene.toml", "--poses", "poses.csv").exit_code == 3


@pytest.fixture
def world(run, tmp_path):
    """A classified UTM terrain, a vehicle mesh and two obstacles: one on it, one at its local origin."""
    x = np.arange(30.0)
    write_asc(tmp_path / "ground.asc", 100 + 0.01 * x[:, None] * x[None, :], xll=X0, yll=Y0)
    assert run("classify", "ground.asc", "-o", "ground.h5").exit_code == 0
    write_tris(tmp_path / "block.obj", box([-1, -1, 0], [1, 1, 3]))
    write_tris(tmp_path / "tank.obj", box([-3, -1.5, 0.4], [3, 1.5, 2.0]))
    (tmp_path / "scene.toml").write_text(
        '[terrain]\npath = "ground.h5"\n\n[vehicle]\npreset = "t72"\nmesh = "tank.obj"\n\n'
        f'[[obstacle]]\nname = "on"\npath = "block.obj"\nposition = [{X0 + 10}, {Y0 + 10}, 100.0]\n\n'
        '[[obstacle]]\nname = "beside"\npath = "block.obj"\nposition = [10.0, 10.0, 100.0]\n\n'
        '[collision]\nk = 26\n')
    return tmp_path


def test_info_json_is_snake_case_nested_objects_without_json_in_strings(run, world):
    result = run("info", "scene.toml", "--json")
    assert result.exit_code == 0, result.stderr
    facts = json.loads(result.stdout)
    bad = []
    for what, where, value in walk_keys(facts):
        if what == "key" and not re.fullmatch(r"[a-z][a-z0-9]*(_[a-z0-9]+)*", value):
            bad.append(where)
        if what == "string" and value.strip()[:1] in ("{", "["):
            with pytest.raises(ValueError):
                json.loads(value)
    assert bad == []
    assert facts["collision"] == {"k": 26, "aabb_levels": 2, "split": "sah", "leaf_size": 4}
    assert isinstance(facts["effects"]["turret_moving"], dict)
    assert facts["terrain"]["extent_x"] == [X0, X0 + 29] and facts["terrain"]["extent_y"] == [Y0, Y0 + 29]
    on, beside = facts["obstacles"]
    assert on["on_terrain"] is True and beside["on_terrain"] is False
    assert on["bounds"] == {"min": [X0 + 9, Y0 + 9, 100.0], "max": [X0 + 11, Y0 + 11, 103.0]}
    assert facts["vehicle"]["mesh"]["triangles"] == 12
    text = run("info", "scene.toml").stdout
    assert re.search(r"on terrain:\s+no\n", text) and re.search(r"on terrain:\s+yes\n", text)
    assert "k 26, aabb levels 2, split sah, leaf size 4" in text


def test_info_json_keys_of_stores_and_trees_are_snake_case_and_trees_have_bounds(run, world):
    assert run("bvh", "--scene", "scene.toml").exit_code == 0
    write_tris(world / "rotated.obj", box([-1, -2, 0], [1, 2, 3]))
    assert run("bvh", "rotated.obj", "-o", "rotated.h5").exit_code == 0
    for path in ("ground.h5", ".tankcd-cache/on.bvh.h5", "rotated.h5"):
        result = run("info", path, "--json")
        assert result.exit_code == 0, result.stderr
        facts = json.loads(result.stdout)
        bad = [where for what, where, value in walk_keys(facts)
               if what == "key" and not re.fullmatch(r"[a-z][a-z0-9]*(_[a-z0-9]+)*", value)]
        assert bad == [], path
        for what, where, value in walk_keys(facts):
            if what == "string" and value.strip()[:1] in ("{", "["):
                with pytest.raises(ValueError):
                    json.loads(value)
    cached = json.loads(run("info", ".tankcd-cache/on.bvh.h5", "--json").stdout)
    assert cached["bounds"] == {"min": [X0 + 9, Y0 + 9, 100.0], "max": [X0 + 11, Y0 + 11, 103.0]}
    assert cached["placement"]["position"] == [X0 + 10, Y0 + 10, 100.0] and cached["placement"]["scale"] == [1.0] * 3
    tree = json.loads(run("info", "rotated.h5", "--json").stdout)
    assert tree["bounds"] == {"min": [-1.0, -2.0, 0.0], "max": [1.0, 2.0, 3.0]}
    assert "bounds:" in run("info", "rotated.h5").stdout


def test_part_ids_and_names_from_a_reader_that_gives_them_reach_the_events(run, tmp_path, monkeypatch):
    """The vehicle side of parts, whatever the readers do today: a mesh read with face_part and
    part_names (faces in no part are "vehicle") names the part in obstacle events."""
    import dataclasses

    from tankcd_cli.collision import obstacles

    hull = box([-3, -1.5, 0.4], [3, 1.5, 2.0])
    turret = box([-1, -1, 2.0], [5, 1, 2.8])
    loose = box([-4, -0.2, 0.6], [-3, 0.2, 1.0])  # behind the hull, in no part
    write_tris(tmp_path / "tank.obj", np.concatenate([hull, turret, loose]))
    write_tris(tmp_path / "post.obj", box([-0.2, -0.2, 0], [0.2, 0.2, 3]))
    (tmp_path / "scene.toml").write_text(
        '[vehicle]\nmesh = "tank.obj"\n\n'
        f'[[obstacle]]\nname = "post"\npath = "post.obj"\nposition = [{X0 + 4}, {Y0}, 0.0]\n')
    read = obstacles.read_mesh

    class WithParts:
        def __init__(self, raw):
            self.__dict__.update({f.name: getattr(raw, f.name) for f in dataclasses.fields(raw)})
            self.face_part = np.array([0] * 12 + [1] * 12 + [-1] * 12, dtype=np.int32)
            self.part_names = ("hull", "turret")

    monkeypatch.setattr(obstacles, "read_mesh",
                        lambda path, up: WithParts(read(path, up)) if path.endswith("tank.obj") else read(path, up))
    (tmp_path / "poses.csv").write_text("step,x,y,z,roll_deg,pitch_deg,yaw_deg\n"
                                        f"0,{X0},{Y0},0,0,0,0\n1,{X0 + 6.5},{Y0},0,0,0,0\n"
                                        f"2,{X0 + 7.5},{Y0},0,0,0,0\n3,{X0 + 20},{Y0},0,0,0,0\n")
    result = run("collide", "--scene", "scene.toml", "--poses", "poses.csv")
    assert result.exit_code == 0, result.stderr
    events = [json.loads(line) for line in result.stdout.splitlines()]
    assert [(e["step"], e["a"]) for e in events] == [(0, "turret"), (1, "hull"), (2, "vehicle")]
    facts = json.loads(run("info", "scene.toml", "--json").stdout)
    assert facts["vehicle"]["mesh"]["parts"] == {"hull": 12, "turret": 12, "vehicle": 12}


@pytest.mark.parametrize("value,ok", [("7", True), ("7.0", True), ("1", False), ("6.5", False), ("true", False)])
def test_road_wheels_are_a_whole_number(run, tmp_path, value, ok):
    (tmp_path / "scene.toml").write_text(f"[vehicle]\nroad_wheels = {value}\n")
    result = run("info", str(tmp_path / "scene.toml"))
    if ok:
        assert result.exit_code == 0, result.stderr
    else:
        assert result.exit_code == 3 and "road_wheels" in result.stderr, result.stderr
        assert len(result.stderr.strip().splitlines()) == 1


def test_entity_tables_first_match_wins(tmp_path):
    from tankcd_cli.scene import load_scene

    path = tmp_path / "s.toml"
    path.write_text('[vehicle]\npreset = "t72"\n\n[[entity]]\nid = "HQ-1"\npreset = "m1"\n\n'
                    '[[entity]]\nmatch = "HQ-*"\npreset = "t55"\ngun_length = 4.5\n\n'
                    '[[entity]]\nmatch = "recon?"\npreset = "m1"\nfuel_drums = true\n')
    scene = load_scene(str(path))
    assert [scene.entity_vehicle(n) for n in ("HQ-1", "HQ-2", "HQ-", "recon7", "recon77", "hq-2", "other")] \
        == [1, 2, 2, 3, 0, 0, 0]  # ids and patterns are case-sensitive, as DIS markings and CSV ids are
    assert scene.entities[1].vehicle.name == "t55" and scene.entities[1].vehicle.gun_length == 4.5
    assert scene.entities[2].vehicle.fuel_drums is True and scene.entities[2].label == "match recon?"


@pytest.mark.parametrize("table, message", [
    ('id = "a"\nmatch = "b*"', "give id (one entity) or match"),
    ('preset = "m1"', "give id (one entity) or match"),
    ('id = ""', "id must be a non-empty text"),
    ('id = 7', "id must be a non-empty text"),
    ('match = "a,b"', "match must be a non-empty text without commas"),
    ('id = "a"\npreset = "t99"', "unknown preset 't99'"),
    ('id = "a"\ncolour = "green"', "unknown key 'colour'"),
    ('id = "a"\nmesh_up = "y"', "mesh_up places the vehicle mesh, but the table names no mesh"),
])
def test_bad_entity_tables_name_their_table(tmp_path, table, message):
    from tankcd_cli.errors import InputError
    from tankcd_cli.scene import load_scene

    path = tmp_path / "s.toml"
    path.write_text(f'[vehicle]\npreset = "t72"\n\n[[entity]]\nid = "ok"\n\n[[entity]]\n{table}\n')
    with pytest.raises(InputError) as err:
        load_scene(str(path))
    assert message in str(err.value) and "[[entity]] 2" in str(err.value)
