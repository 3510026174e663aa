"""tankcd bvh, collide and info on scenes, as scripts run them."""

import json
import os
from pathlib import Path

import pytest

from tankcd_cli.vehicle_mesh import box


def write_obj(path, tris):
    with open(path, "w") as fh:
        for tri in tris:
            for v in tri:
                fh.write("v %r %r %r\n" % tuple(float(c) for c in v))
        for i in range(len(tris)):
            fh.write(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n")


OBSTACLE_EVENT_FIELDS = {"step", "t", "kind", "a", "b", "point", "contacts"}
SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


@pytest.fixture
def scene(tmp_path):
    write_obj(tmp_path / "block.obj", box([-1, -1, 0], [1, 1, 3]))
    (tmp_path / "scene.toml").write_text(
        '[vehicle]\npreset = "t72"\n\n[[obstacle]]\nname = "block"\npath = "block.obj"\n'
        'position = [500010.0, 4500000.0, 0.0]\nyaw_deg = 45\n')
    rows = ["step,t,x,y,z,roll_deg,pitch_deg,yaw_deg"]
    for k, x in enumerate([500000.0, 500006.0, 500020.0]):
        rows.append(f"{k},{k * 0.5},{x},4500000,0,0,0,0")
    rows.append("3,1.5,,,,,,")  # a pose replay could not make: skipped, not an error
    (tmp_path / "poses.csv").write_text("\n".join(rows) + "\n")
    return tmp_path


def test_collide_reports_the_block(run, scene):
    result = run("collide", "--scene", "scene.toml", "--poses", "poses.csv")
    assert result.exit_code == 0, result.stderr
    events = [json.loads(line) for line in result.stdout.splitlines()]
    assert {e["step"] for e in events} == {1}  # only the pose whose front reaches the block
    # one event per part in contact: the hull's front and the gun over it
    assert sorted(e["a"] for e in events) == ["gun", "hull"]
    for e in events:
        assert e["kind"] == "obstacle" and e["b"] == "block"
        assert set(e) == OBSTACLE_EVENT_FIELDS  # replay's obstacle events have these
    assert "(1 without a pose)" in result.stderr
    assert "trees: k 18, aabb levels 2, split sah, leaf size 4" in result.stderr
    assert os.path.exists(scene / ".tankcd-cache" / "block.bvh.h5")


def test_fail_on_collision_and_events_file(run, scene):
    result = run("collide", "--scene", "scene.toml", "--poses", "poses.csv", "--events", "ev.jsonl", "--fail-on-collision")
    assert result.exit_code == 1
    assert len((scene / "ev.jsonl").read_text().splitlines()) == 2  # the hull and the gun


def test_cached_tree_is_reused_and_a_changed_mesh_rebuilt(run, scene):
    assert run("bvh", "--scene", "scene.toml").exit_code == 0
    again = run("-v", "bvh", "--scene", "scene.toml")
    assert "cached" in again.stderr
    write_obj(scene / "block.obj", box([-1, -1, 0], [1, 1, 4]))
    changed = run("-v", "bvh", "--scene", "scene.toml")
    assert "stale" in changed.stderr


def test_bvh_of_a_model_and_info(run, scene):
    result = run("bvh", "block.obj", "--k", "26", "--aabb-levels", "1", "--split", "sah", "-o", "block.h5")
    assert result.exit_code == 0, result.stderr
    info = run("info", "block.h5").stdout
    assert "bounding-volume tree" in info and "k:" in info and "nodes per level" in info
    facts = json.loads(run("info", "block.h5", "--json").stdout)
    assert facts["k"] == 26 and facts["aabb_nodes"] == 1


def test_info_scene_lists_effects(run, scene):
    res = run("info", "scene.toml")
    assert res.exit_code == 0, res.stderr
    assert "block" in res.stdout
    facts = json.loads(run("info", "scene.toml", "--json").stdout)
    # obstacles make obstacle checks run; the gun against the drums only with a turret that moves
    assert facts["effects"]["turret_moving"]["obstacles"] is True
    assert facts["effects"]["turret_still"]["internal"] is False
    assert facts["effects"]["turret_moving"]["internal"] is True
    (block,) = facts["obstacles"]
    assert block["name"] == "block" and block["triangles"] == 12


@pytest.mark.parametrize("text,fragment", [
    ('[vehicle]\npreset = "t99"\n', "[vehicle] preset"),
    ('[vehicle]\ntrack_lenght = 4\n', "[vehicle] track_lenght: unknown key"),
    ('[vehicle]\ntrack_length = "long"\n', "[vehicle] track_length: must be a number"),
    ('[vehicle]\ntrack_length = -4\n', "track_length must be a positive length"),
    ('[[obstacle]]\nname = "x"\npath = "missing.obj"\n', "[[obstacle]] 1 path: file not found"),
    ('[[obstacle]]\nname = "x"\npath = "block.obj"\nposition = [1, 2]\n', "position must be three finite numbers"),
    ('[collision]\nk = 7\n', "[collision] k"),
    ('[terrain\npath = 1', "not valid TOML"),
])
def test_scene_validation_names_the_key(run, scene, text, fragment):
    (scene / "bad.toml").write_text(text)
    result = run("info", "bad.toml")
    assert result.exit_code == 3
    assert "bad.toml" in result.stderr and fragment in result.stderr, result.stderr


def test_collide_events_are_replays_obstacle_events(run, tmp_path):
    """The same kind carries the same fields: collide on replay's poses gives replay's obstacle events
    at the rows (the patrol without its turret columns: the poses carry no turret angles)."""
    scene = SAMPLE / "scene.toml"
    lines = (SAMPLE / "patrol.csv").read_text().splitlines()
    (tmp_path / "still.csv").write_text("\n".join(",".join(line.split(",")[:4]) for line in lines) + "\n")
    replayed = run("replay", "still.csv", "--scene", scene, "--poses", "p.csv", "--events", "r.jsonl", "--discrete")
    assert replayed.exit_code == 0, replayed.stderr
    collided = run("collide", "--scene", scene, "--poses", "p.csv", "--events", "c.jsonl")
    assert collided.exit_code == 0, collided.stderr
    ours = [json.loads(line) for line in (tmp_path / "c.jsonl").read_text().splitlines()]
    theirs = [json.loads(line) for line in (tmp_path / "r.jsonl").read_text().splitlines()]
    theirs = [e for e in theirs if e["kind"] == "obstacle"]
    assert ours and {frozenset(e) for e in ours} == {frozenset(e) for e in theirs} == {frozenset(OBSTACLE_EVENT_FIELDS)}
    assert [(e["step"], e["a"], e["b"], e["contacts"]) for e in ours] == \
        [(e["step"], e["a"], e["b"], e["contacts"]) for e in theirs]


@pytest.mark.parametrize("args,message", [
    (["--poses", "p.parquet"], "Invalid value for '--poses': p.parquet: Parquet input is not supported yet; give .csv"),
    (["--poses", "poses.csv", "--events", "e.parquet"],
     "Invalid value for '--events': e.parquet: Parquet output is not supported yet; write .jsonl"),
])
def test_parquet_is_a_usage_error(run, scene, args, message):
    result = run("collide", "--scene", "scene.toml", *args)
    assert result.exit_code == 2
    assert result.stderr.endswith(f"Error: {message}\n"), result.stderr
    assert not (scene / "e.parquet").exists()
