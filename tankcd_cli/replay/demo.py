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
    from tankcd_cli.collision.obstacles import load_obstacles
    from tankcd_cli.io.atomic import atomic_path, committed_together
    from tankcd_cli.io.events import event_line
    from tankcd_cli.io.poses_csv import format_rows, header
    from tankcd_cli.io.trajectory import read_trajectory
    from tankcd_cli.matching.match import PLACED_BY, STATUS
    from tankcd_cli.plots import grid_map_png, replay_map_png
    from tankcd_cli.replay.pipeline import prepare, replay_chunks
    from tankcd_cli.sample import write_sample
    from tankcd_cli.scene import load_scene
    from tankcd_cli.terrain.open import classify_file, open_terrain

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
    scene = load_scene(scene_path)
    say("building the obstacles' trees")
    load_obstacles(scene, cache=True, rebuild=True, progress=say)
    surface = open_terrain(store).surface
    chunks = list(read_trajectory(p("patrol.csv")))
    setup = prepare(surface, scene.vehicle, scene, turret_moves=chunks[0].has_turret, progress=say)
    say("replaying the patrol")
    counts = {"obstacle": 0, "internal": 0, "terrain": 0, "off_terrain": 0}
    path, marks = [], []
    with committed_together(), atomic_path(p("poses.csv"), ".csv") as tmp_poses, \
            atomic_path(p("events.jsonl"), ".jsonl") as tmp_events:
        with open(tmp_poses, "w", newline="") as poses_out, open(tmp_events, "w") as events_out:
            poses_out.write(header())
            for chunk, poses, events in replay_chunks(setup, chunks):
                poses_out.write(format_rows(chunk.step, chunk.t, poses, PLACED_BY, STATUS))
                path.append(poses.position[:, :2])
                for e in events:
                    counts[e.kind] += 1
                    events_out.write(event_line(e.step, e.t, e.kind, e.a, e.b, **e.extra))
                    marks.append((e.kind, chunk.x[e.step - chunk.step[0]], chunk.y[e.step - chunk.step[0]]))
    import numpy as np

    with atomic_path(p("replay.png"), ".png") as tmp:
        replay_map_png(store, np.concatenate(path), marks, tmp)
    summary = {"directory": out_dir, "rows": int(sum(len(c) for c in chunks)), "events": counts,
               "effects": setup.effects,
               "files": ["battlefield.h5", "classes.png", "poses.csv", "events.jsonl", "replay.png", "scene.toml"]}
    with open(p("summary.json"), "w") as fh:
        json.dump(summary, fh, indent=2)
    return summary
