"""Valid inputs of every format the tool reads, small, and how to feed each to a command.

Used by the malformed-input matrix and the fuzzing harness: both start from these
and break them.
"""

from __future__ import annotations

import numpy as np

ASC = ("ncols 6\nnrows 5\nxllcenter 500000.0\nyllcenter 4500000.0\ncellsize 2.0\nNODATA_value -9999\n"
       + "".join(" ".join(f"{100 + 0.1 * r + 0.05 * c * c:.3f}" for c in range(6)) + "\n" for r in range(5)))


def _obj():
    lines = [f"v {x:.1f} {y:.1f} {0.1 * np.sin(x) + 0.05 * y:.4f}" for y in range(5) for x in range(6)]
    for r in range(4):
        for c in range(5):
            a = r * 6 + c + 1
            lines += [f"f {a} {a + 1} {a + 7}", f"f {a} {a + 7} {a + 6}"]
    return "\n".join(lines) + "\n"


OBJ = _obj()
TRAJECTORY = "t,x,y,yaw_deg,turret_deg,gun_deg\n" + "".join(
    f"{0.1 * k:.1f},{500004.0 + 0.1 * k:.3f},{4500004.0:.3f},{5.0 * k - 180:.1f},{12.0 * k:.1f},-2.0\n" for k in range(30))
POSES = "step,x,y,z,roll_deg,pitch_deg,yaw_deg\n" + "".join(
    f"{k},{500004.0 + 0.2 * k:.3f},4500004.000,100.5,0.5,-1.0,{10.0 * k:.1f}\n" for k in range(20))
WALL_OBJ = ("v 500006 4500000 99\nv 500006 4500008 99\nv 500006 4500008 103\nv 500006 4500000 103\n"
            "f 1 2 3\nf 1 3 4\n")


def scene_text(terrain: str, wall: str) -> str:
    return (f'[terrain]\npath = "{terrain}"\n\n[vehicle]\npreset = "t72"\n\n'
            f'[[obstacle]]\nname = "wall"\npath = "{wall}"\nposition = [0.0, 0.0, 0.0]\n')


# format -> (file name, valid text)
VALID = {
    "asc": ("ground.asc", ASC),
    "obj": ("ground.obj", OBJ),
    "trajectory": ("traj.csv", TRAJECTORY),
    "poses": ("poses.csv", POSES),
}


def setup(tmp_path, run):
    """Write the valid files, a store and a scene; returns a dict of paths."""
    paths = {}
    for fmt, (name, text) in VALID.items():
        paths[fmt] = tmp_path / name
        paths[fmt].write_text(text)
    (tmp_path / "wall.obj").write_text(WALL_OBJ)
    paths["store"] = tmp_path / "ground.h5"
    assert run("classify", paths["asc"], "-o", paths["store"]).exit_code == 0
    paths["scene"] = tmp_path / "scene.toml"
    paths["scene"].write_text(scene_text(paths["store"].name, "wall.obj"))
    paths["tree"] = tmp_path / "wall.bvh.h5"
    assert run("bvh", tmp_path / "wall.obj", "-o", paths["tree"]).exit_code == 0
    return paths


def command(fmt: str, bad, paths: dict, out) -> list:
    """The command that reads a file of format ``fmt`` (the bad one), writing to ``out`` where it writes."""
    if fmt in ("asc", "obj"):
        return ["classify", bad, "-o", out]
    if fmt == "trajectory":
        return ["replay", bad, "--scene", paths["scene"], "--poses", out]
    if fmt == "poses":
        return ["collide", "--scene", paths["scene"], "--poses", bad, "--events", out]
    if fmt == "scene":
        return ["replay", paths["trajectory"], "--scene", bad, "--poses", out]
    if fmt in ("store", "tree"):
        return ["info", bad]
    raise ValueError(fmt)
