"""The effects' registry is the one list: its kinds are docs/formats.md's, in that order, and every
effect's counts, seconds and flags are the keys a replay's summary reports."""

import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from tankcd_cli.replay import records
from tankcd_cli.replay.effects import (ALL_KINDS, EFFECTS, EVENT_KINDS, KINDS, OWN, Effects, Event, effects_for,
                                       resolution, seconds_keys)
from tankcd_cli.vehicle import vehicle_preset
from tests.replay.scenes import flat, replay_csv, scene

FORMATS = Path(__file__).resolve().parents[3] / "docs" / "formats.md"


def _documented_kinds() -> list[str]:
    """The first column of the events' "By kind" table in docs/formats.md."""
    text = FORMATS.read_text()
    table = text[text.index("By kind:"):].split("\n\n")[1]
    rows = [line for line in table.splitlines() if line.startswith("|")][2:]  # less the header and its rule
    return [re.match(r"\|\s*`([a-z_]+)`", row).group(1) for row in rows]


def test_the_registry_lists_the_kinds_docs_formats_md_lists_in_its_order():
    assert list(ALL_KINDS) == _documented_kinds()
    assert len(set(ALL_KINDS)) == len(ALL_KINDS)  # each kind one effect's


def test_the_records_kinds_are_the_registrys():
    assert records.KINDS == KINDS == ("obstacle", "internal", "terrain")
    assert records.EVENT_KINDS == EVENT_KINDS == KINDS + ("off_terrain",)
    assert records.Event is Event  # one Event type


def test_effects_say_which_run_and_travel_to_workers():
    t72, m1 = vehicle_preset("t72"), vehicle_preset("m1")
    assert effects_for(t72, False, True).as_dict() == {"terrain_contact": True, "obstacles": False, "internal": True}
    assert effects_for(t72, True, False).as_dict() == {"terrain_contact": True, "obstacles": True, "internal": False}
    assert effects_for(m1, True, True).internal is (bool(m1.fuel_drums))
    e = effects_for(t72, True, True)
    assert pickle.loads(pickle.dumps(e)) == e and e["obstacles"] and [x.name for x in e.running()] == [
        "terrain", "obstacles", "internal"]
    assert Effects.any_of([Effects(True, False, False), Effects(True, True, False)]) == Effects(True, True, False)
    with pytest.raises(TypeError):
        Effects(True, False)


def test_every_effects_keys_are_in_the_summary(run, tmp_path):
    """An exercise of two tanks with turret columns in a scene with an obstacle: every effect runs,
    and the summary names each one's counts, seconds, flag and resolution."""
    flat(tmp_path)
    scene(tmp_path, [("post", [80.0, 5.0, 95.0], [80.2, 5.2, 105.0])])
    rows = "t,entity,x,y,yaw_deg,turret_deg,gun_deg\n" + "".join(
        f"{k},{name},{40 + k},{y},0,{150 - 20 * k},-6\n" for k in range(3) for name, y in (("a", 30), ("b", 40)))
    result, events, summary = replay_csv(run, tmp_path, rows)
    assert result.exit_code == 0, result.stderr
    assert list(summary["collisions"]) == list(KINDS)
    assert list(summary["between"]) == list(EVENT_KINDS)
    assert "vehicle_contacts" in summary and "off_terrain" in summary
    assert list(summary["effects"]) == [e.flag for e in OWN]
    assert summary["effects"] == {"terrain_contact": True, "obstacles": True, "internal": True}
    assert list(summary["seconds_by_effect"]) == seconds_keys(True, True)
    assert {e.name for e in EFFECTS} <= set(summary["seconds_by_effect"])
    surface = type("Grid", (), {"spacing": np.array([1.0, 1.0])})()
    assert set(resolution(surface)) <= set(summary["motion"])
    assert {e["kind"] for e in events} <= set(ALL_KINDS)


def test_a_discrete_replay_of_one_vehicle_reports_the_own_effects_only(run, tmp_path):
    flat(tmp_path)
    scene(tmp_path)
    _, _, summary = replay_csv(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n1,41,30,0\n", "--discrete")
    assert list(summary["seconds_by_effect"]) == seconds_keys(False, False) == [
        "matching", "terrain", "obstacles", "internal"]
