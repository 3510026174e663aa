"""The trajectory input formats' registry (tankcd_cli.io.trajectory.formats.INPUT_FORMATS) and
docs/formats.md's table of them say the same; what reads the registry (the reader, info, export's and
replay's --format, describe) takes every format from it."""

import re
from pathlib import Path

from click.testing import CliRunner

from tankcd_cli.cli.main import cli
from tankcd_cli.io.trajectory.formats import FORMAT_NAMES, INPUT_FORMATS, format_of_head, format_of_suffix

FORMATS_MD = Path(__file__).resolve().parents[3] / "docs" / "formats.md"


def _documented() -> dict:
    """{format: (suffixes, suffixes told by the first bytes, magic numbers as hex)} from the table of
    formats.md's "Trajectory inputs: formats"."""
    text = FORMATS_MD.read_text()
    section = text[text.index("## Trajectory inputs: formats"):]
    start = section.index("| format (`--format`) | suffixes | first bytes | read as |")
    rows = {}
    for line in section[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        name, suffixes, first, _ = (c.strip() for c in line.strip("|").split("|"))
        decided, _, by_bytes = suffixes.partition("(and")
        rows[name.strip("`")] = (tuple(re.findall(r"`(\.[a-z0-9.]+)`", decided)),
                                 tuple(re.findall(r"`(\.[a-z0-9.]+)`", by_bytes)),
                                 set(re.findall(r"`([0-9a-f]{8})`", first)))
    return rows


def test_the_registry_and_formats_md_list_the_same_formats_suffixes_and_magic_numbers():
    documented = _documented()
    assert list(documented) == list(FORMAT_NAMES)
    for f in INPUT_FORMATS:
        suffixes, by_bytes, magics = documented[f.name]
        assert suffixes == f.suffixes, f.name
        assert by_bytes == f.content_suffixes, f.name
        # each magic as the table writes it, in one byte order or the other
        assert {m.hex() if m.hex() in magics else m[::-1].hex() for m in f.magics} == magics, f.name


def test_every_registered_suffix_and_magic_tells_its_format():
    for f in INPUT_FORMATS:
        for suffix in f.suffixes:
            assert format_of_suffix(f"run{suffix}") == (f.name, False)
            assert format_of_suffix(f"run{suffix.upper()}.gz") == (f.name, True)
        for magic in f.magics:
            assert format_of_head(magic + bytes(20)) == f.name
    assert format_of_head(b"  <?xml") == "gpx" and format_of_head(b"t,x,y,yaw_deg\n") is None


def test_the_command_line_offers_the_registered_formats():
    for command in ("replay", "export"):
        out = CliRunner().invoke(cli, [command, "--help"], terminal_width=200).output
        choices = re.search(r"--format \[([^\]]+)\]", out).group(1)
        assert choices.split("|") == list(FORMAT_NAMES), command
