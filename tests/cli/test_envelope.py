"""tankcd envelope: what the drums do to the gun, said as it is; options that cannot apply refused."""

import re
from pathlib import Path

import pytest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


def _report(result):
    """The closing line without its timing."""
    return re.sub(r" \(\d+\.\d+ s\)$", "", result.stderr.strip().splitlines()[-1])


def test_a_vehicle_without_drums_says_so(run):
    result = run("envelope", "--vehicle", "m1", "--step", "30")
    assert result.exit_code == 0, result.stderr
    assert _report(result) == ("envelope: m1, 12 azimuths: no fuel drums fitted: the gun's own depression limit, "
                               "-10.0 deg, holds at every azimuth")
    rows = result.stdout.splitlines()[1:]
    assert len(rows) == 12 and all(r.endswith(",-10.00,gun,true") for r in rows)


def test_a_scene_without_drums_says_so(run, tmp_path):
    (tmp_path / "s.toml").write_text('[vehicle]\npreset = "t72"\nfuel_drums = false\n')
    result = run("envelope", "--scene", "s.toml", "--step", "90")
    assert result.exit_code == 0, result.stderr
    assert _report(result) == ("envelope: t72, 4 azimuths: no fuel drums fitted: the gun's own depression limit, "
                               "-6.0 deg, holds at every azimuth")


def test_drums_that_limit_say_over_how_much(run):
    result = run("envelope", "--vehicle", "t72")
    assert result.exit_code == 0, result.stderr
    assert _report(result) == ("envelope: t72, 360 azimuths: the fuel drums limit depression over 37 deg of "
                               "azimuth, to at worst -2.61 deg (gun limit -6.0 deg)")


def test_vehicle_with_scene_is_a_usage_error(run):
    result = run("envelope", "--scene", SAMPLE / "scene.toml", "--vehicle", "m1")
    assert result.exit_code == 2
    assert result.stderr.endswith("Error: --vehicle does not apply with --scene: the scene's [vehicle] table decides "
                                  "the vehicle (set its preset there)\n")


def test_parquet_output_is_a_usage_error(run, tmp_path):
    result = run("envelope", "-o", "e.parquet")
    assert result.exit_code == 2
    assert result.stderr.endswith("Error: Invalid value for '-o' / '--output': e.parquet: Parquet output is not "
                                  "supported yet; write .csv\n")
    assert not (tmp_path / "e.parquet").exists()


@pytest.mark.parametrize("args", [["--png", "-"], ["--png", "-", "-o", "-"]])
def test_two_outputs_on_stdout_is_a_usage_error(run, args):
    result = run("envelope", *args)
    assert result.exit_code == 2
    assert result.stderr.endswith("Error: -o/--output and --png both go to standard output (-): give one of them a "
                                  "file\n")


def test_png_to_stdout_with_the_table_in_a_file(run, tmp_path):
    result = run("envelope", "--step", "90", "--png", "-", "-o", "e.csv")
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "e.csv").read_text().startswith("azimuth_deg,min_elevation_deg,limited_by,checked\n")
