"""Likely set-up slips warn (and --strict makes them exit 3 with nothing written); outputs never
overwrite inputs or each other (exit 2, both files as they were)."""

import json
import os

import numpy as np
import pytest

from tankcd_cli.terrain.mesh.clean import height_field_problems
from tankcd_cli.vehicle_mesh import box
from tests.conftest import write_asc, write_obj

X0, Y0 = 500000.0, 4500000.0  # UTM-like


def _grid_mesh(nx=30, ny=20, step=2.0, seed=0):
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(nx) * step, np.arange(ny) * step)
    z = np.sin(x / 7) * np.cos(y / 5) + rng.normal(0, 0.05, x.shape)
    v = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    a = (np.arange(ny - 1)[:, None] * nx + np.arange(nx - 1)[None, :]).ravel()
    f = np.concatenate([np.column_stack([a, a + 1, a + nx + 1]), np.column_stack([a, a + nx + 1, a + nx])])
    return v, f


def _closed_box():
    t = box([0, 0, 0], [10, 10, 3], 2)
    return t.reshape(-1, 3), np.arange(len(t) * 3).reshape(-1, 3)


def _sphere(n=24):
    th, ph = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 2 * n))
    v = np.column_stack([(np.sin(th) * np.cos(ph)).ravel(), (np.sin(th) * np.sin(ph)).ravel(), np.cos(th).ravel()])
    m = th.shape[1]
    a = (np.arange(th.shape[0] - 1)[:, None] * m + np.arange(m - 1)[None, :]).ravel()
    f = np.concatenate([np.column_stack([a, a + 1, a + m + 1]), np.column_stack([a, a + m + 1, a + m])])
    return v * 5.0, f


# --- the height-field test itself -----------------------------------------------------------

def test_a_terrain_passes_and_closed_or_turned_meshes_do_not():
    v, f = _grid_mesh()
    assert height_field_problems(v, f) == []
    assert height_field_problems(v, f[:, ::-1]) == []  # winding does not matter
    assert any("overlap in plan" in p for p in height_field_problems(*_closed_box()))
    assert any("overlap in plan" in p for p in height_field_problems(*_sphere()))
    turned = np.column_stack([v[:, 0], -v[:, 2], v[:, 1]])  # the terrain read with the wrong up axis
    problems = height_field_problems(turned, f)
    assert any("taller" in p for p in problems) and any("steeper" in p for p in problems)


# --- warnings and --strict ------------------------------------------------------------------

def test_closed_object_as_terrain_warns_and_strict_writes_nothing(run, tmp_path):
    write_obj(tmp_path / "box.obj", *_closed_box())
    res = run("classify", "box.obj", "-o", "box.h5")
    assert res.exit_code == 0, res.stderr
    assert "warning: box.obj" in res.stderr and "closed object" in res.stderr
    res = run("--strict", "classify", "box.obj", "-o", "strict.h5")
    assert res.exit_code == 3 and "(--strict)" in res.stderr
    assert not (tmp_path / "strict.h5").exists()
    res = run("classify", "box.obj", "-o", "strict2.h5", "--strict")  # after the command too
    assert res.exit_code == 3 and not (tmp_path / "strict2.h5").exists()


def test_y_up_mesh_read_as_z_up_suggests_up_y(run, tmp_path):
    v, f = _grid_mesh()
    write_obj(tmp_path / "yup.obj", np.column_stack([v[:, 0], v[:, 2], -v[:, 1]]), f)  # as a y-up exporter writes
    res = run("classify", "yup.obj", "-o", "a.h5")
    assert res.exit_code == 0 and "--up y" in res.stderr
    res = run("classify", "yup.obj", "-o", "b.h5", "--up", "y")
    assert res.exit_code == 0 and "warning" not in res.stderr


def test_gltf_is_y_up_by_default_and_up_z_says_so(run, tmp_path):
    """glTF is y-up by its specification: classify, bvh and replay read it so without --up."""
    import trimesh

    v, f = _grid_mesh()
    trimesh.Trimesh(np.column_stack([v[:, 0], v[:, 2], -v[:, 1]]), f, process=False).export(str(tmp_path / "t.glb"))
    res = run("classify", "t.glb", "-o", "a.h5")
    assert res.exit_code == 0 and "warning" not in res.stderr, res.stderr
    res = run("classify", "t.glb", "-o", "b.h5", "--up", "z")
    assert res.exit_code == 0 and "--up y" in res.stderr
    import h5py

    with h5py.File(tmp_path / "a.h5") as h5:  # turned back to z up: the heights are the terrain's
        np.testing.assert_allclose(np.sort(h5["mesh/vertices"][:, 2]), np.sort(v[:, 2]), atol=1e-6)
    assert run("bvh", "t.glb", "-o", "t.bvh.h5").exit_code == 0
    with h5py.File(tmp_path / "t.bvh.h5") as h5:
        assert json.loads(h5.attrs["placement"]) == {"up": "y"}  # the axis applied, not "None"


@pytest.fixture
def utm_store(run, tmp_path):
    x = np.arange(60.0)
    write_asc(tmp_path / "g.asc", np.sin(x[:40, None] / 7) * np.cos(x[None, :] / 5) + 100, xll=X0, yll=Y0)
    assert run("classify", "g.asc", "-o", "g.h5").exit_code == 0
    return tmp_path / "g.h5"


def _trajectory(path, x0, y0, rows=40):
    path.write_text("t,x,y,yaw_deg\n" + "".join(f"{i * 0.1},{x0 + 10 + i * 0.5},{y0 + 20},0\n" for i in range(rows)))
    return path


def test_trajectory_beside_the_terrain_warns_fails_and_strict_writes_nothing(run, tmp_path, utm_store):
    _trajectory(tmp_path / "local.csv", 0.0, 0.0)  # local coordinates over a UTM terrain
    res = run("replay", "local.csv", "--terrain", utm_store, "--poses", "p.csv")
    assert res.exit_code == 0
    assert "40 of 40 rows are off the terrain" in res.stderr and "500000.0" in res.stderr
    rows = (tmp_path / "p.csv").read_text().splitlines()[1:]
    assert len(rows) == 40 and all(r.endswith(",none,,,off") for r in rows)  # no matcher placed them
    assert run("replay", "local.csv", "--terrain", utm_store, "--poses", "p.csv",
               "--fail-on-collision").exit_code == 1
    assert run("replay", "local.csv", "--terrain", utm_store, "--poses", "p.csv", "--fail-on-collision",
               "--allow-off-terrain").exit_code == 0
    res = run("replay", "local.csv", "--terrain", utm_store, "--poses", "q.csv", "--events", "e.jsonl", "--strict")
    assert res.exit_code == 3 and not (tmp_path / "q.csv").exists() and not (tmp_path / "e.jsonl").exists()
    _trajectory(tmp_path / "utm.csv", X0, Y0)
    res = run("replay", "utm.csv", "--terrain", utm_store, "--poses", "u.csv", "--strict", "--fail-on-collision")
    assert res.exit_code == 0, res.stderr
    assert "warning" not in res.stderr


def test_obstacle_beside_the_terrain_warns(run, tmp_path, utm_store):
    write_obj(tmp_path / "crate.obj", *_closed_box())
    scene = tmp_path / "s.toml"
    scene.write_text(f'[terrain]\npath = "{utm_store}"\n[[obstacle]]\nname = "crate"\npath = "crate.obj"\n'
                     'position = [10.0, 10.0, 0.0]\n')  # the UTM offset forgotten
    _trajectory(tmp_path / "utm.csv", X0, Y0)
    res = run("replay", "utm.csv", "--scene", scene, "--poses", "p.csv")
    assert res.exit_code == 0 and "obstacle 'crate' lies off the terrain" in res.stderr
    res = run("replay", "utm.csv", "--scene", scene, "--poses", "p2.csv", "--strict")
    assert res.exit_code == 3 and not (tmp_path / "p2.csv").exists()


def test_vehicle_with_a_scene_is_a_usage_error(run, tmp_path, utm_store):
    scene = tmp_path / "s.toml"
    scene.write_text(f'[terrain]\npath = "{utm_store}"\n')
    _trajectory(tmp_path / "utm.csv", X0, Y0)
    res = run("replay", "utm.csv", "--scene", scene, "--vehicle", "m1", "--poses", "p.csv")
    assert res.exit_code == 2 and "--vehicle" in res.stderr and not (tmp_path / "p.csv").exists()


def test_collide_on_a_trajectory_points_at_replay(run, tmp_path, utm_store):
    scene = tmp_path / "s.toml"
    scene.write_text(f'[terrain]\npath = "{utm_store}"\n')
    _trajectory(tmp_path / "utm.csv", X0, Y0)
    res = run("collide", "--scene", scene, "--poses", "utm.csv")
    assert res.exit_code == 3 and "tankcd replay" in res.stderr


# --- outputs against inputs -------------------------------------------------------------------

def _snapshot(paths):
    return {p: p.read_bytes() if p.exists() else None for p in paths}


def test_every_output_input_clash_exits_2_and_leaves_both(run, tmp_path, utm_store):
    traj = _trajectory(tmp_path / "utm.csv", X0, Y0)
    os.link(traj, tmp_path / "hard.csv")  # another name of the same file
    scene = tmp_path / "s.toml"
    scene.write_text(f'[terrain]\npath = "{utm_store}"\n')
    write_obj(tmp_path / "crate.obj", *_closed_box())
    (tmp_path / "poses.csv").write_text("keep me\n")
    files = [traj, scene, utm_store, tmp_path / "crate.obj", tmp_path / "poses.csv"]
    cases = [
        ("replay", "utm.csv", "--terrain", utm_store, "--poses", "utm.csv"),
        ("replay", "utm.csv", "--terrain", utm_store, "--poses", "hard.csv"),
        ("replay", "utm.csv", "--terrain", utm_store, "--poses", "./sub/../utm.csv"),
        ("replay", "utm.csv", "--terrain", utm_store, "--poses", "poses.csv", "--events", "poses.csv"),
        ("replay", "utm.csv", "--scene", scene, "--poses", "x.csv", "--summary", "s.toml"),
        ("replay", "utm.csv", "--terrain", utm_store, "--poses", "x.csv", "--png", utm_store),
        ("replay", "utm.csv", "--scene", scene, "--poses", utm_store),  # the scene's terrain
        ("classify", utm_store, "--method", "jet"),  # would rewrite its input store
        ("classify", "crate.obj", "-o", "crate.obj"),
        ("classify", "crate.obj", "-o", "c.h5", "--png", "crate.obj"),
        ("classify", "crate.obj", "-o", "c.h5", "--png", "c.h5"),
        ("bvh", "crate.obj", "-o", "crate.obj"),
        ("envelope", "-o", "poses.csv", "--png", "poses.csv"),
        ("collide", "--scene", scene, "--poses", "poses.csv", "--events", "poses.csv"),
    ]
    (tmp_path / "sub").mkdir()
    before = _snapshot(files)
    for args in cases:
        res = run(*args)
        assert res.exit_code == 2, (args, res.stderr)
        assert " is also " in res.stderr, (args, res.stderr)
        assert _snapshot(files) == before, args
    assert not (tmp_path / "x.csv").exists() and not (tmp_path / "c.h5").exists()


# --- summary and map --------------------------------------------------------------------------

def test_summary_to_a_file_or_stdout_and_the_map(run, tmp_path, utm_store):
    write_obj(tmp_path / "crate.obj", *_closed_box())
    scene = tmp_path / "s.toml"
    scene.write_text(f'[terrain]\npath = "{utm_store}"\n[[obstacle]]\nname = "crate"\npath = "crate.obj"\n'
                     f'position = [{X0 + 25}, {Y0 + 15}, 99.0]\n')
    _trajectory(tmp_path / "utm.csv", X0, Y0)
    res = run("replay", "utm.csv", "--scene", scene, "--poses", "p.csv", "--summary", "sum.json", "--png", "map.png",
              "--png-colour", "matcher")
    assert res.exit_code == 0, res.stderr
    summary = json.loads((tmp_path / "sum.json").read_text())
    assert summary["rows"] == 40 and summary["collisions"]["obstacle"] > 0
    assert (tmp_path / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = run("replay", "utm.csv", "--scene", scene, "--poses", "p.csv", "--summary", "-")
    assert res.exit_code == 0 and json.loads(res.stdout)["rows"] == 40
    res = run("replay", "utm.csv", "--scene", scene, "--summary", "-")  # poses already on stdout
    assert res.exit_code == 2
