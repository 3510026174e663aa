"""The README's examples run as written (from the repository's top, with its sample data)."""

import re
from pathlib import Path

TOP = Path(__file__).resolve().parent.parent


def test_the_python_api_example_runs(monkeypatch, capsys):
    text = (TOP / "README.md").read_text()
    section = text[text.index("## Python API"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(TOP)
    exec(compile(code, "README.md (Python API)", "exec"), {})
    out = capsys.readouterr().out
    assert "1144 poses;" in out and "wheel_stations" in out
