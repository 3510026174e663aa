"""The whole pipeline on the sample battlefield: what ``tankcd demo`` runs."""

from __future__ import annotations

import json
import os
from typing import Callable


def run_demo(out_dir: str, progress: Callable[[str], None] | None = None) -> dict:
    """Generate the sample data in ``out_dir``, classify the terrain, build the obstacles' trees,
    replay the patrol through the scene, and draw the path over the class map.

    Returns a summary (files written, rows, collisions by kind).
    """
    import numpy as np

    from tankcd_cli.collision.obstacles import load_obstacles
    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.plots import grid_map_png, replay_map_png
    from tankcd_cli.replay.effects import EVENT_KIND_TABLE
    from tankcd_cli.replay.records import ReplayOutputs
    from tankcd_cli.replay.run import run_replay
    from tankcd_cli.replay.world import WorldSpec
    from tankcd_cli.sample import write_sample
    from tankcd_cli.scene import load_scene
    from tankcd_cli.terrain.open import classify_file

    say = progress or (lambda s: None)
    os.makedirs(out_dir, exist_ok=True)
    say(f"writing the sample battlefield into {out_dir}")
    write_sample(out_dir)
    p = lambda name: os.path.join(out_dir, name)  # noqa: E731
    scene_path = p("scene.toml")
    with open(scene_path) as fh:
        text = fh.read().replace('path = "battlefield.asc"', 'path = "battlefield.h5"')
    with open(scene_path, "w") as fh:
        fh.write(text)
    say("classifying the terrain")
    store = p("battlefield.h5")
    classify_file(p("battlefield.asc"), store)
    with atomic_path(p("classes.png"), ".png") as tmp:
        grid_map_png(store, tmp)
    say("building the obstacles' trees")
    load_obstacles(load_scene(scene_path), cache=True, rebuild=True, progress=say)
    world = WorldSpec(scene=scene_path).load(progress=say)
    say("replaying the patrol")
    path, marks = [], []

    def draw(chunk, poses, events):
        if chunk is None:  # the vehicles' last contacts (an exercise's; the patrol has none): no row to mark
            return
        path.append(poses.position[:, :2])
        for e in events:
            k = e.step - chunk.step[0] if e.step >= chunk.step[0] else 0  # a contact between rows: its row's place
            marks.append((e.kind, chunk.x[k], chunk.y[k]))

    result = run_replay(world, p("patrol.csv"), ReplayOutputs(p("poses.csv"), p("events.jsonl")), observe=draw)
    with atomic_path(p("replay.png"), ".png") as tmp:
        replay_map_png(store, np.concatenate(path), marks, tmp, kinds=EVENT_KIND_TABLE)
    summary = {"directory": out_dir, "rows": result.rows,
               "events": {**result.collisions, "off_terrain": result.off_terrain},
               "between": result.between, "effects": result.effects,
               "files": ["battlefield.h5", "classes.png", "poses.csv", "events.jsonl", "replay.png", "scene.toml"]}
    with open(p("summary.json"), "w") as fh:
        json.dump(summary, fh, indent=2)
    return summary
