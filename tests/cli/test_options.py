"""The shared option checks of cli/options.py, as each command that uses them shows them."""

from pathlib import Path

import pytest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"
STDIN_SCENE = ("Error: Invalid value for '--scene': a scene is read from a file (the paths it names are relative "
               "to it), not from standard input\n")


@pytest.mark.parametrize("args", [
    ["bvh", "--scene", "-"],
    ["collide", "--scene", "-", "--poses", "p.csv"],
    ["envelope", "--scene", "-"],
    ["replay", "t.csv", "--scene", "-"],
    ["tradeoff", "--scene", "-", "--quick"],
])
def test_a_scene_from_stdin_is_a_usage_error(run, args):
    result = run(*args, input=(SAMPLE / "scene.toml").read_text())
    assert result.exit_code == 2
    assert result.stderr.endswith(STDIN_SCENE), result.stderr


def test_check_option_combinations_spells_options_as_the_help_does():
    import click
    from click.testing import CliRunner

    from tankcd_cli.cli.options import Excludes, Needs, check_option_combinations

    rules = (Needs("colour", "png", "it colours the drawing"), Excludes("output", "scene", "the scene decides"),
             Needs("jobs", "fleet mode", "fleets only"))

    @click.command()
    @click.option("-o", "--output")
    @click.option("--scene")
    @click.option("--png")
    @click.option("--png-colour", "colour")
    @click.option("--jobs", type=int)
    def cmd(output, scene, png, colour, jobs):
        check_option_combinations(click.get_current_context(), rules, {"fleet mode": False})

    def error(*args):
        result = CliRunner().invoke(cmd, list(args))
        return result.exit_code, result.output.splitlines()[-1]

    assert error("--png-colour", "x") == (2, "Error: --png-colour needs --png: it colours the drawing")
    assert error("-o", "a", "--scene", "s") == (2, "Error: -o/--output does not apply with --scene: the scene decides")
    assert error("--jobs", "2") == (2, "Error: --jobs needs fleet mode: fleets only")
    assert CliRunner().invoke(cmd, ["--png", "p", "--png-colour", "x", "-o", "a"]).exit_code == 0


@pytest.mark.parametrize("args,option", [
    (["demo", "-"], "'[DIRECTORY]'"),
    (["tradeoff", "--out", "-", "--quick"], "'--out'"),
    (["replay", "t.csv", "--terrain", "t.h5", "--out-dir", "-"], "'--out-dir'"),
])
def test_an_output_directory_named_dash_is_a_usage_error(run, tmp_path, args, option):
    result = run(*args)
    assert result.exit_code == 2
    assert result.stderr.endswith(f"Error: Invalid value for {option}: several files go into this directory: give "
                                  "a directory, not - (standard output)\n"), result.stderr
    assert not (tmp_path / "-").exists()


def test_replay_says_which_vehicle_it_replays(run):
    text = " ".join(run("replay", "--help").stdout.split())
    assert "Vehicle preset replayed, with --terrain (a scene's [vehicle] table decides with --scene); its " \
           "footprint also sizes the classes of a terrain classified on the fly." in text
