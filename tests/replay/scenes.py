"""Small scenes for the replay's tests: a flat grid, boxes as obstacles, a T-72 with or without a
hull-sized mesh, and a replay of CSV rows through the command line."""

import json

import numpy as np

from tests.conftest import write_asc, write_obj

GROUND = 100.0


def flat(tmp_path, cols=120, rows=60, x0=0.0, y0=0.0, bump=None):
    z = np.full((rows, cols), GROUND)
    if bump is not None:
        bump(z, x0, y0)
    return write_asc(tmp_path / "ground.asc", z, 1.0, x0, y0)


def box_obj(path, lo, hi):
    from tankcd_cli.vehicle_mesh import box

    tris = box(lo, hi)
    write_obj(path, tris.reshape(-1, 3), np.arange(len(tris) * 3).reshape(-1, 3))
    return path


def scene(tmp_path, obstacles=(), vehicle="", terrain="ground.asc"):
    text = f'[terrain]\npath = "{terrain}"\n\n[vehicle]\npreset = "t72"\n{vehicle}\n'
    for name, lo, hi in obstacles:
        box_obj(tmp_path / f"{name}.obj", lo, hi)
        text += f'\n[[obstacle]]\nname = "{name}"\npath = "{name}.obj"\nposition = [0.0, 0.0, 0.0]\n'
    (tmp_path / "scene.toml").write_text(text)
    return tmp_path / "scene.toml"


def replay_csv(run, tmp_path, rows, *extra):
    (tmp_path / "t.csv").write_text(rows)
    result = run("replay", "t.csv", "--scene", "scene.toml", "--poses", "p.csv", "--events", "e.jsonl", "--summary",
                 *extra)
    events = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    summary = json.loads(result.stderr.strip().splitlines()[-1])
    return result, events, summary


def hull_mesh(tmp_path):
    # a T-72-sized box: hull length and width, from ground clearance to the turret roof
    box_obj(tmp_path / "tank.obj", [-3.43, -1.73, 0.49], [3.43, 1.73, 2.19])
    return 'mesh = "tank.obj"\n'


def wall_scene(tmp_path, lo, hi, vehicle=None):
    flat(tmp_path)
    return scene(tmp_path, [("wall", lo, hi)], vehicle if vehicle is not None else hull_mesh(tmp_path))
