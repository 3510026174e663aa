"""tankcd bvh: build and save bounding-volume trees."""

from __future__ import annotations

import os

import click

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.store import write_tree
from tankcd_cli.cli.options import (
    Excludes,
    Needs,
    check_option_combinations,
    no_stdin,
    refuse_clashes,
    verbosity_options,
)
from tankcd_cli.collision.obstacles import cache_path, load_obstacles
from tankcd_cli.io.atomic import atomic_path
from tankcd_cli.io.terrain_readers import read_terrain
from tankcd_cli.names import KDOP_KS, SPLITS, TREE_DEFAULTS, UP_AXES
from tankcd_cli.scene import load_scene

SCENE_DECIDES = "the scene's [collision] table sets how its trees are built, as replay and collide build them"
RULES = (
    Excludes("output", "scene", "a scene's trees go to its cache, .tankcd-cache/NAME.bvh.h5 beside the scene, "
                                "where replay and collide find them"),
    *(Excludes(name, "scene", SCENE_DECIDES) for name in ("k", "aabb_levels", "split", "leaf_size")),
    Excludes("up", "scene", "each [[obstacle]]'s up key decides"),
    Excludes("fmt", "scene", "a scene's obstacles are read by their suffixes"),
    Needs("force", "scene", "a MODEL's tree is always built"),
)


@click.command(short_help="Build a serialized bounding-volume tree of a model or of a scene's obstacles.")
@click.argument("model", required=False, type=click.Path(allow_dash=True))
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True), default=None,
              help="MODEL's tree (default: MODEL's stem + .bvh.h5 beside it; - for stdout).")
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin,
              help="Instead of MODEL: build (or refresh) the trees of every obstacle of this scene as replay "
                   "and collide use them, with the scene's [collision] settings, into .tankcd-cache/ beside it.")
@click.option("--k", "k", type=click.Choice([str(k) for k in KDOP_KS]), default=str(TREE_DEFAULTS["k"]), show_default=True,
              help="k-DOP type (6 is the AABB); MODEL's tree only (a scene's trees take its [collision] table).")
@click.option("--aabb-levels", type=click.IntRange(0, 64), default=TREE_DEFAULTS["aabb_levels"], show_default=True,
              help="Top levels that use only the AABB (the paper's hybrid); 0: all k-DOP; MODEL's tree only.")
@click.option("--split", type=click.Choice(SPLITS), default=TREE_DEFAULTS["split"], show_default=True,
              help="Split rule: the surface-area heuristic, or the median of the longest axis; MODEL's tree only.")
@click.option("--leaf-size", type=click.IntRange(1, 64), default=TREE_DEFAULTS["leaf_size"], show_default=True,
              help="Triangles per leaf; MODEL's tree only.")
@click.option("--up", type=click.Choice(UP_AXES), default=None,
              help="Up axis of MODEL (default: the format's convention, y for glTF and GLB, z for the rest).")
@click.option("--format", "fmt", default=None, metavar="FMT",
              help="MODEL's format when the suffix does not say (needed for stdin): obj, ply, stl, off, glb, ...")
@click.option("--force", is_flag=True, help="With --scene: rebuild even up-to-date trees.")
@verbosity_options
@click.pass_obj
def bvh(report, model, output, scene, k, aabb_levels, split, leaf_size, up, fmt, force):
    """Build a bounding-volume tree over MODEL's triangles (in its own frame) and save it,
    or with --scene build the world trees of every obstacle and cache them beside the scene.
    MODEL may be - for standard input (give --format and -o).

    A scene's trees are built as replay and collide build them, with its [collision] table's
    k, aabb_levels, split and leaf_size, so that they find them up to date: -o and the tree
    options apply to MODEL and are usage errors with --scene."""
    if model and scene:
        raise click.UsageError("give MODEL or --scene, not both")
    check_option_combinations(click.get_current_context(), RULES)
    if model and model.lower().endswith(".toml") and fmt is None:
        raise click.UsageError(f"MODEL {model} is a scene: give it as --scene {model}")
    report.kernels()
    step = report.progress("bvh")
    if scene:
        sc = load_scene(scene)
        obstacles = load_obstacles(sc, cache=True, rebuild=force, progress=step)
        for spec, ob in zip(sc.obstacles, obstacles):
            report.info(f"bvh: {ob.name}: {len(ob.tree.triangles):,} triangles, {ob.tree.nodes:,} nodes -> "
                        f"{cache_path(sc, spec)}")
        report.info(f"bvh: {len(obstacles)} obstacle tree(s) up to date ({report.elapsed():.2f} s)")
        return
    if not model:
        raise click.UsageError("give MODEL or --scene")

    if model == "-" and output is None:
        raise click.UsageError("reading MODEL from stdin needs -o/--output")
    output = output or os.path.splitext(model)[0] + ".bvh.h5"
    refuse_clashes({"MODEL": model}, {"-o/--output": output})
    raw = read_terrain(model, up=up, fmt=fmt)
    step(f"building over {len(raw.faces):,} triangles")
    tree = build_tree(raw.vertices[raw.faces], k=int(k), leaf_size=leaf_size, aabb_levels=aabb_levels, split=split)
    tree.attrs.update({"source": raw.source, "source_sha256": raw.sha256, "placement": f'{{"up": "{raw.up}"}}'})
    with atomic_path(output, ".h5") as tmp:
        write_tree(tmp, tree)
    d = tree.describe()
    source = "<stdin>" if model == "-" else model
    report.info(f"bvh: {source} -> {output}: {d['triangles']:,} triangles, {d['nodes']:,} nodes, depth {d['depth']}, "
                f"k = {d['k']}, {d['aabb_nodes']} AABB and {d['kdop_nodes']} k-DOP nodes ({report.elapsed():.2f} s)")
