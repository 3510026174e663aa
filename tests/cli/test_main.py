"""The tankcd group: -q and -v, one rule, stated in every help and kept."""

from pathlib import Path

import pytest

from tankcd_cli.cli.main import COMMANDS

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"
QUIET_HELP = "Only errors on stderr (no warnings, progress or closing report line; --strict still fails on a warning)."
CONTRADICTION = "Error: -q/--quiet and -v/--verbose contradict each other: give one of them\n"


def _one_line(text):
    return " ".join(text.split())


@pytest.mark.parametrize("command", [[]] + [[name] for name in sorted(COMMANDS)])
def test_every_help_states_the_quiet_rule(run, command):
    result = run(*command, "--help")
    assert result.exit_code == 0
    assert QUIET_HELP in _one_line(result.stdout)


def test_group_help_says_quiet_keeps_only_errors(run):
    assert "-q keeps only errors (set-up warnings too go unsaid: --strict makes them errors)" in \
        _one_line(run("--help").stdout)


@pytest.mark.parametrize("where", ["before", "after"])
def test_quiet_drops_warnings_and_the_report_line_but_strict_still_fails(run, where):
    # a closed object classified as a terrain: a set-up warning, then the closing report line
    args = ["classify", SAMPLE / "depot.obj", "-o", "d.h5"]
    loud = run(*args)
    assert loud.exit_code == 0
    assert "tankcd: warning: " in loud.stderr and "classify: " in loud.stderr
    quiet = run(*(["-q"] + args if where == "before" else args + ["-q"]))
    assert quiet.exit_code == 0
    assert quiet.stderr == ""
    strict = run(*(["-q", "--strict"] + args if where == "before" else args + ["-q", "--strict"]))
    assert strict.exit_code == 3 and strict.stderr.startswith("tankcd: error: ") and "(--strict)" in strict.stderr


def test_quiet_keeps_errors(run):
    result = run("-q", "classify", "missing.asc", "-o", "m.h5")
    assert result.exit_code == 3
    assert result.stderr.startswith("tankcd: error: missing.asc")


@pytest.mark.parametrize("args", [
    ["-q", "-v", "info", "x.h5"],
    ["-v", "info", "x.h5", "-q"],
    ["-q", "info", "x.h5", "-v"],
    ["info", "x.h5", "-q", "-v"],
])
def test_quiet_with_verbose_is_a_usage_error(run, args):
    result = run(*args)
    assert result.exit_code == 2
    assert result.stderr.endswith(CONTRADICTION)


@pytest.mark.parametrize("args", [["-v", "classify"], ["classify", "-v"]])
def test_verbose_before_or_after_the_command(run, args):
    result = run(*args, SAMPLE / "battlefield.asc", "-o", "b.h5")
    assert result.exit_code == 0
    assert "battlefield.asc: 161 rows x 241 columns of posts, 1 m (x) x 1 m (y) apart, local grid (no CRS)\n" \
        in result.stderr
