"""tankcd bvh: a model's tree, or a scene's trees as replay and collide build them; each option applies or is
refused."""

from pathlib import Path

import pytest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


def _usage_error(result, message):
    assert result.exit_code == 2, result.stderr
    assert result.stderr.endswith(f"Error: {message}\n"), result.stderr


SCENE_DECIDES = "the scene's [collision] table sets how its trees are built, as replay and collide build them"


@pytest.mark.parametrize("args,message", [
    (["--k", "6"], f"--k does not apply with --scene: {SCENE_DECIDES}"),
    (["--leaf-size", "16"], f"--leaf-size does not apply with --scene: {SCENE_DECIDES}"),
    (["--aabb-levels", "0"], f"--aabb-levels does not apply with --scene: {SCENE_DECIDES}"),
    (["--split", "median"], f"--split does not apply with --scene: {SCENE_DECIDES}"),
    (["--k", "18"], f"--k does not apply with --scene: {SCENE_DECIDES}"),  # even the default, when given
    (["-o", "x.h5"], "-o/--output does not apply with --scene: a scene's trees go to its cache, "
                     ".tankcd-cache/NAME.bvh.h5 beside the scene, where replay and collide find them"),
    (["--up", "y"], "--up does not apply with --scene: each [[obstacle]]'s up key decides"),
    (["--format", "obj"], "--format does not apply with --scene: a scene's obstacles are read by their suffixes"),
    ([str(SAMPLE / "depot.obj")], "give MODEL or --scene, not both"),
])
def test_model_options_with_scene_are_usage_errors(run, tmp_path, args, message):
    _usage_error(run("bvh", "--scene", SAMPLE / "scene.toml", *args), message)
    assert not (tmp_path / "x.h5").exists()


def test_the_issue_command_writes_nothing_and_says_why(run, tmp_path):
    result = run("bvh", "--scene", SAMPLE / "scene.toml", "--k", "6", "--leaf-size", "16", "-o", "x.h5")
    assert result.exit_code == 2
    assert not (tmp_path / "x.h5").exists()


def test_force_needs_scene(run):
    _usage_error(run("bvh", SAMPLE / "depot.obj", "--force"), "--force needs --scene: a MODEL's tree is always built")


def test_a_scene_given_as_model(run):
    _usage_error(run("bvh", SAMPLE / "scene.toml"),
                 f"MODEL {SAMPLE / 'scene.toml'} is a scene: give it as --scene {SAMPLE / 'scene.toml'}")


def test_model_from_stdin(run, tmp_path):
    text = (SAMPLE / "depot.obj").read_text()
    _usage_error(run("bvh", "-", "--format", "obj", input=text), "reading MODEL from stdin needs -o/--output")
    result = run("bvh", "-", "--format", "obj", "-o", "d.h5", input=text)
    assert result.exit_code == 0, result.stderr
    assert result.stderr.startswith("bvh: <stdin> -> d.h5: 48 triangles")
    assert (tmp_path / "d.h5").read_bytes()[:8] == b"\x89HDF\r\n\x1a\n"


def test_tree_to_stdout(run):
    result = run("bvh", SAMPLE / "depot.obj", "-o", "-", "--k", "6")
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes[:8] == b"\x89HDF\r\n\x1a\n"


def test_tree_options_apply_to_a_model(run, tmp_path):
    result = run("bvh", SAMPLE / "depot.obj", "--k", "6", "--leaf-size", "16", "--aabb-levels", "0", "-o", "d.h5")
    assert result.exit_code == 0, result.stderr
    assert "k = 6" in result.stderr and (tmp_path / "d.h5").exists()


def test_help_says_what_applies_to_a_scene(run):
    text = " ".join(run("bvh", "--help").stdout.split())
    assert "-o and the tree options apply to MODEL and are usage errors with --scene" in text
    assert "with the scene's [collision] settings, into .tankcd-cache/ beside it" in text


def test_a_missing_model_is_no_such_file(run):
    result = run("bvh", "missing.h5")
    assert result.exit_code == 3
    assert result.stderr == "tankcd: error: missing.h5: no such file\n"
